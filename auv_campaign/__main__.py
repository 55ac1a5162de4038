"""``python -m auv_campaign campaign|tune ...`` (what ``auv-hil campaign`` and ``auv-hil tune`` run)."""

from __future__ import annotations

import sys

from auv_campaign.cli import main

if __name__ == "__main__":
    sys.exit(main())
