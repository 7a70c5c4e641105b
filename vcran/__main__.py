import sys

from vcran.cli import main

sys.exit(main())
