"""``python -m railfem.cli``: the ``railfem`` command."""
import sys

from . import main

if __name__ == "__main__":  # guarded: importing railfem.cli.__main__ must not run anything
    sys.exit(main())
