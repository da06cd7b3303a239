import sys

from bimrobot.cli import main

sys.exit(main())
