import sys

from multiloop.cli import main

sys.exit(main())
