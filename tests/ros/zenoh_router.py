"""A Zenoh router on one endpoint, multicast scouting off: ``python -m tests.ros.zenoh_router tcp/127.0.0.1:PORT``.

Prints ``up`` once listening and serves until killed (tests kill it to simulate a router going away).
"""

from __future__ import annotations

import sys
import threading

from mrs_nav.bridge.config import zenoh_settings
from mrs_nav.bridge.session import open_session

if __name__ == "__main__":
    session = open_session(zenoh_settings("router", [sys.argv[1]], []))
    print("up", flush=True)
    threading.Event().wait()
