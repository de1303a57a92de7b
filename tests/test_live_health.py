"""Recovery in sight (issue 49): ``ares run`` says on stderr, as it happens, when a stage is
paused (and why), resumed (after how long), re-grabbed (and why), and how the links' trouble
counters stand -- a 60 s pause for an unplugged grabber no longer looks like a hang."""

from __future__ import annotations

from ares.cli import main
from test_usb_transient import AT, _scan


def _stderr(tmp_path, capsys, *faults):
    rc = main(["run", str(_scan(tmp_path)), "--out", str(tmp_path / "run"),
               *[a for f in faults for a in ("--sim-fault", f)]])
    return rc, capsys.readouterr().err


def test_pause_resume_and_link_counters_are_shown(tmp_path, capsys):
    rc, err = _stderr(tmp_path, capsys, f"usb_disconnect_at={AT}", "usb_gone_s=60")
    assert rc == 0, err
    lines = err.splitlines()
    paused = [x for x in lines if x.startswith("Paused at stage 1: ")]
    resumed = [x for x in lines if x.startswith("Resumed at stage 1 after ")]
    assert len(paused) == 1 and "disconnected" in paused[0], err
    assert len(resumed) == 1 and float(resumed[0].split("after ")[1].split(" s")[0]) >= 60, err
    assert lines.index(paused[0]) < lines.index(resumed[0])


def test_regrab_and_its_reason_are_shown_with_the_link_statistics(tmp_path, capsys):
    rc, err = _stderr(tmp_path, capsys, f"usb_stall_at={AT}")
    assert rc == 0, err
    assert any(x.startswith("Regrab of stage 1: ") and "stalled" in x for x in err.splitlines()), err
    assert any(x.startswith("link: frames ") and "1 stalls" in x for x in err.splitlines()), err


def test_the_window_shows_pause_regrab_and_link_health(tmp_path):
    """The window's models (no Qt): a Health event per pause/resume/re-grab sets the run state
    and its message; the links' trouble counters go to the Information items."""
    from ares.gui import events as G
    from ares.gui.models import progress as P
    from ares.gui.models.session import SessionModel
    from ares.gui.runner_adapter import RunnerJob
    from ares.scan import events as ev

    got = []
    run = RunnerJob.__new__(RunnerJob)  # only its event translation
    run._emit = got.append
    run._on_event(ev.Paused(1, "USB frame grabber: device disconnected"))
    run._on_event(ev.LinkHealth(1, {"frames": {"stalls": 1}}))
    run._on_event(ev.Resumed(1, 61.5))
    assert [g.kind for g in got] == ["paused", "link", "resumed"]
    assert got[0].stage == 1 and got[0].text.startswith("Paused at stage 1: ")  # the index, as in the files
    s = SessionModel()
    s.handle(got[0])
    assert s.progress.state == P.PAUSED and "disconnected" in s.progress.message
    s.handle(got[1])
    assert s.info.items["link health"] == "frames 1 stalls"
    s.handle(got[2])
    assert s.progress.state == P.RUNNING and "after 61.5 s" in s.progress.message
    assert isinstance(got[0], G.Health)
