import sys

from mrhyst.cli import main

sys.exit(main())
