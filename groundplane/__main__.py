"""``python -m groundplane``: the same as the ``groundplane`` command."""
import sys

from .cli import main

sys.exit(main())
