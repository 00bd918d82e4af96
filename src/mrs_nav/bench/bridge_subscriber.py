"""One remote subscriber of ``mrs-nav bench bridge``, in a process of its own as a remote user's would be.

Run as ``python -m mrs_nav.bench.bridge_subscriber --connect ENDPOINT --zenoh-config FILE --ready FILE --out FILE``
once the bridge listens. It opens its own client session (TLS and certificates from the Zenoh JSON5 file),
subscribes to each topic (:meth:`mrs_nav.bench.bridge.Receiver.subscribe`), creates the ``--ready`` file, and
on SIGINT writes what it received (:meth:`mrs_nav.bench.bridge.Received.to_json`): per topic and
``header.seq`` its wall-clock receive time and the bridge's. Its Zenoh callbacks run under its own interpreter
lock only, so no other subscriber delays them.
"""

from __future__ import annotations

import argparse
import signal
from pathlib import Path

from mrs_nav.atomic_write import write_text
from mrs_nav.bench.bridge import Receiver
from mrs_nav.bridge.session import open_client_session


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--connect", required=True, help="the bridge's endpoint, e.g. tls/127.0.0.1:7447")
    parser.add_argument("--zenoh-config", default="", help="Zenoh JSON5 file of the client (TLS)")
    parser.add_argument("--ready", required=True, help="file created once subscribed")
    parser.add_argument("--out", required=True, help="JSON written on SIGINT")
    args = parser.parse_args(argv)
    receiver = Receiver()
    session = open_client_session([args.connect], "client", args.zenoh_config)
    try:
        receiver.subscribe(session)
        Path(args.ready).touch()
        signal.pause()  # the bench's SIGINT ends the wait (KeyboardInterrupt)
    except KeyboardInterrupt:
        pass
    finally:
        session.close()  # type: ignore[no-untyped-call]
    write_text(args.out, receiver.received().to_json(), "bench subscriber results")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
