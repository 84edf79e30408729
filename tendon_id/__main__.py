import sys

from tendon_id.cli import main

sys.exit(main())
