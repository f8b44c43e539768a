"""``python -m groundplane``: the same as the ``groundplane`` command."""
import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
