"""Jobs behind the command line, one module per command: parameters in, files in a folder.

A job calls library functions and writes what they return (atomically, railfem.atomic);
jobs never import each other. Shared helpers (progress, slugs, the job's mesh,
CSV text) are in ``common``: the only module a job imports from this package.
"""
