"""``python -m bkabem_ros ...`` = ``bkabem ...``."""

import sys

from bkabem_ros.main import main

sys.exit(main())
