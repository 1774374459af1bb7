import sys

from enn_traffic.cli import main

sys.exit(main())
