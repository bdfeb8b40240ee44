import sys

from flexmbd.cli import main

sys.exit(main())
