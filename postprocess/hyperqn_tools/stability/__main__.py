import sys

from hyperqn_tools.stability.suite import main

sys.exit(main())
