"""Files the host reads, trusted no further than their bounds: ``bounded`` (regular files
of a stated size, JSON without recursion or giant integers), ``csv_dialect`` (the strict
CSV dialect), ``tabular`` and ``tabular_blocks`` (tables with their units line); and how it
writes: ``atomic`` (every whole file, replaced or left as it was, never over what is not a
file) and ``folder_lock`` (one writer per run folder)."""
