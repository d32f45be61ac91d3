import sys

from litl.report.cli import main

sys.exit(main())
