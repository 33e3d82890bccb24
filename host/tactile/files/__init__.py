"""Files the host reads, trusted no further than their bounds: ``bounded`` (regular files
of a stated size, JSON without recursion or giant integers), ``csv_dialect`` (the strict
CSV dialect: lines, records, cells), ``tabular`` (the CSV reader: blocks of rows, tables,
``#`` lines)."""
