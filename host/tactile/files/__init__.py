"""Files the host reads, trusted no further than their bounds: ``bounded`` (regular files
of a stated size, JSON without recursion or giant integers), ``csv_dialect`` (the strict
CSV dialect: lines, records, cells; a header-less matrix and the ``#`` lines), ``tabular``
(CSV tables: blocks of rows in NumPy, a whole table); and how it writes: ``writing`` (every
whole file, replaced or left as it was, never over what is not a file; one writer per run
folder)."""
