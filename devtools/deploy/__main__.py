"""`python -m devtools.deploy`: see devtools/deploy/__init__.py."""

import sys

from . import main

sys.exit(main())
