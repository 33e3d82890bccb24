"""Files the host reads, trusted no further than their bounds: ``bounded`` (regular files
of a stated size, JSON without recursion or giant integers), ``csv_dialect`` (the strict
CSV dialect: lines, records, cells; a header-less matrix and the ``#`` lines), ``tabular``
(CSV tables: blocks of rows in NumPy, a whole table); and how it writes: ``atomic`` (every
whole file, replaced or left as it was, never over what is not a file) and ``folder_lock``
(one writer per run folder)."""
