"""``mrs-nav monitor``'s command line: a malformed ``--connect`` endpoint is one ERROR line naming it, before any
Zenoh session is opened."""

from __future__ import annotations

import pytest

from mrs_nav.cli.main import main


@pytest.mark.parametrize("fleet", [[], ["--fleet"]])
@pytest.mark.parametrize("endpoint", ["nonsense", "127.0.0.1:7447", "tcp/", "tcp/127.0.0.1:7447,bad"])
def test_a_malformed_endpoint_is_one_error_line_naming_it(
    endpoint: str, fleet: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["monitor", "--connect", endpoint, "--snapshot", "unused.json", "--timeout", "1", *fleet]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("ERROR: endpoint ")
    assert "expected PROTO/ADDRESS" in err
    assert "\n" not in err
