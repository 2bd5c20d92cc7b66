"""``python -m simx_server [scene.xml] [options]``: the same program as ``simx-server``."""

import sys

from simx_server.cli import main

if __name__ == "__main__":
    sys.exit(main())
