"""``python -m app.cli``: the ``oscillators`` command without the installed script."""

import sys

import numpy as np

from app.cli import main

if __name__ == "__main__":
    np.seterr(all="ignore")
    sys.exit(main())
