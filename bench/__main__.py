"""``python -m bench list`` / ``python -m bench run NAME... --repeat N`` (``bench/harness.py``)."""
import sys

from bench.harness import main

sys.exit(main())
