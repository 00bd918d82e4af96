"""The rule by which a node decides that its master was lost or restarted (mrs_nav.master_restart)."""

from __future__ import annotations

from mrs_nav.master_restart import MasterChange, MasterLiveness, MasterState

LOST = MasterChange(MasterState.LOST)


def test_the_same_master_answering_changes_nothing() -> None:
    liveness = MasterLiveness()
    assert [liveness.observe(pid) for pid in (40, 40, 40)] == [None, None, None]


def test_a_master_stopped_and_started_again_is_lost_once_then_back_once() -> None:
    liveness = MasterLiveness()
    seen = [liveness.observe(pid) for pid in (40, None, None, None, 77, 77)]
    assert seen == [None, LOST, None, None, MasterChange(MasterState.BACK, 77), None]


def test_a_master_back_with_the_same_pid_is_back_all_the_same() -> None:
    # a roscore restarted in a container may get its old pid: its registrations are gone all the same
    liveness = MasterLiveness()
    assert [liveness.observe(pid) for pid in (1, None, 1)] == [None, LOST, MasterChange(MasterState.BACK, 1)]


def test_a_master_restarted_between_two_polls_is_back_without_a_loss() -> None:
    liveness = MasterLiveness()
    assert [liveness.observe(pid) for pid in (40, 77, 77)] == [None, MasterChange(MasterState.BACK, 77), None]


def test_a_master_absent_at_the_first_poll_is_back_when_it_answers() -> None:
    liveness = MasterLiveness()
    assert [liveness.observe(pid) for pid in (None, 40)] == [LOST, MasterChange(MasterState.BACK, 40)]
