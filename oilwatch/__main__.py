import sys

from oilwatch.cli import main

sys.exit(main())
