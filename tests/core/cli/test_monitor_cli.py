"""``mrs-nav monitor``'s command line: a malformed ``--connect`` endpoint, ``--prefix`` or ``--snapshot`` is one
ERROR line naming it, before any Zenoh session is opened or any bridge asked."""

from __future__ import annotations

import pytest

from mrs_nav.cli.main import main
from tests.rosharness import free_port


def error_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err.strip()
    assert "\n" not in err
    return err


@pytest.mark.parametrize("fleet", [[], ["--fleet"]])
@pytest.mark.parametrize(
    "endpoint",
    ["nonsense", "127.0.0.1:7447", "tcp/", "tcp/127.0.0.1:7447,bad", "tcp/127.0.0.1:99999", "tcp/[::1", "tcp/robot"],
)
def test_a_malformed_endpoint_is_one_error_line_naming_it(
    endpoint: str, fleet: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["monitor", "--connect", endpoint, "--timeout", "1", *fleet]) == 1
    err = error_line(capsys)
    assert err.startswith("ERROR: endpoint ")
    assert "no bridge" not in err


@pytest.mark.parametrize("fleet", [[], ["--fleet"]])
@pytest.mark.parametrize("prefix", ["a//b", "**", "a?b#c", "mrs nav"])
def test_a_malformed_prefix_is_one_error_line_with_or_without_fleet(
    prefix: str, fleet: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    assert main(["monitor", "--connect", endpoint, "--once", "--timeout", "1", "--prefix", prefix, *fleet]) == 1
    assert error_line(capsys) == f"ERROR: key prefix {prefix!r}: expected chunks of letters, digits, '_', '-', '.'"


def test_an_empty_prefix_needs_fleet(capsys: pytest.CaptureFixture[str]) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    assert main(["monitor", "--connect", endpoint, "--once", "--timeout", "1", "--prefix", ""]) == 1
    assert error_line(capsys).startswith("ERROR: key prefix '': the monitor reads the mrs_nav key layout")


@pytest.mark.parametrize(("snapshot", "why"), [(".", "is a folder"), ("/proc/x.png", "cannot write into /proc")])
def test_an_unwritable_snapshot_is_refused_before_connecting(
    snapshot: str, why: str, capsys: pytest.CaptureFixture[str]
) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    assert main(["monitor", "--connect", endpoint, "--once", "--timeout", "5", "--snapshot", snapshot]) == 1
    err = error_line(capsys)  # no bridge is there: it would say so after 5 s if the snapshot were not checked first
    assert err.startswith("ERROR: --snapshot: ")
    assert why in err
