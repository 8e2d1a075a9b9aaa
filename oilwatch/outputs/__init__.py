"""What every command does with its outputs: whole files, one writer per folder, honest stops.

* :mod:`.atomic`: a file appears whole under its final name or not at all (a temporary name in the same
  folder, written, synced, renamed); a folder likewise (:func:`.atomic.atomic_folder`).
* :mod:`.rows`: a CSV stream that holds whole rows only (:class:`.rows.RowFile`): flushed at row
  boundaries, cut back to the last whole row when a write fails.
* :mod:`.lock`: one writer per output folder (:func:`.lock.output_lock`), the holder named in the refusal.
* :mod:`.interrupts`: SIGINT and SIGTERM turned into :class:`.interrupts.Interrupted` (exit codes 130 and
  143), held back while a row or a rename is under way.
* :mod:`.ledger`: what the running command has kept so far, for the one line printed when it stops early
  (interrupted, disk full, unwritable).

The user documentation is docs/operations.md.
"""
