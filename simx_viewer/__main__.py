"""``python -m simx_viewer``: the same as ``simx-viewer``."""

import sys

from simx_viewer.app import main

sys.exit(main())
