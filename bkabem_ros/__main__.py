"""``python -m bkabem_ros ...`` = ``bkabem ...``."""

import sys

from bkabem_ros.cli.main import main

sys.exit(main())
