import sys

from litl.claims.cli import main

sys.exit(main())
