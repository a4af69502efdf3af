"""bench/eval_worlds.py's tasks give the same rows wherever they run: one after the other,
in two processes, and as Ray tasks; the rows stored in a database read back as printed."""
from __future__ import annotations

import os
import sys

import pytest

BENCH = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "bench")
sys.path.insert(0, BENCH)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import eval_worlds  # noqa: E402
from eval_results import ResultSink, show_results  # noqa: E402

#: Two small tasks: two worlds, two seeds, two legs each.
TASKS = [("office", 1), ("simple", 2)]
LEGS = 2


def study(rows):
    """The rows without what measures the machine (rtf, setup)."""
    return [{k: v for k, v in r.items() if k not in eval_worlds.TIMING} for r in rows]


@pytest.fixture(scope="module")
def serial():
    return eval_worlds.run_tasks(TASKS, LEGS, workers=1)


def test_serial_rows_are_the_tasks_in_order(serial):
    assert [(r["world"], r["seed"], r["legs"]) for r in serial] == [("office", 1, 2),
                                                                     ("simple", 2, 2)]
    assert all(0.0 <= r["tracked"] <= 1.0 and r["rtf"] > 0 for r in serial)
    # different seeds and worlds: different studies (the comparison below can fail)
    assert study(serial)[0] != dict(study(serial)[1], world="office", seed=1)


def test_two_processes_give_the_serial_rows(serial, tmp_path):
    stored = []
    rows = eval_worlds.run_tasks(TASKS, LEGS, workers=2, on_row=stored.append)
    assert study(rows) == study(serial)
    assert sorted((r["world"], r["seed"]) for r in stored) == sorted(TASKS)


def test_ray_tasks_give_the_serial_rows(serial):
    pytest.importorskip("ray")
    rows = eval_worlds.run_tasks(TASKS, LEGS, ray_address="local")
    assert study(rows) == study(serial)


def test_rows_stored_read_back_as_a_table(serial, tmp_path, capsys):
    db = str(tmp_path / "db")
    sink = ResultSink(db, journal_dir=str(tmp_path / "journal"))
    for r in serial:
        sink.add(r)
    notes = sink.close()
    assert notes == ["2 row(s) stored in %s (bullet_floor_sim.eval_results)" % db]
    capsys.readouterr()
    assert show_results(db, journal_dir=str(tmp_path / "journal")) == 0
    out = capsys.readouterr().out
    lines = [ln for ln in out.splitlines() if ln.startswith("EVAL ")]
    assert len(lines) == 2
    assert lines[0].startswith("EVAL world=office seed=1 legs=2 given_up=%.3f" % serial[0]["given_up"])
    assert " tracked=%.3f " % serial[1]["tracked"] in lines[1]
    assert "note: commit " in out and "2 row(s) from" in out


def test_two_machines_fill_one_mongodb_table(serial, tmp_path, capsys):
    from mongo_server import MongoServer, find_launcher

    launcher, why = find_launcher()
    if launcher is None:
        pytest.skip("no MongoDB wire server: %s" % why)
    server = MongoServer(launcher, str(tmp_path / "server")).start()
    try:
        for k, r in enumerate(serial):     # each "machine" stores its own task's row
            sink = ResultSink(server.uri, journal_dir=str(tmp_path / ("journal%d" % k)))
            sink.source["host"] = "machine%d" % k
            sink.add(r)
            assert sink.close()[0].startswith("1 row(s) stored in mongodb://")
        capsys.readouterr()
        assert show_results(server.uri, journal_dir=str(tmp_path / "j")) == 0
        out = capsys.readouterr().out
        evals = [ln for ln in out.splitlines() if ln.startswith("EVAL ")]
        assert [ln.split()[1] for ln in evals] == ["world=office", "world=simple"]
        assert "2 row(s) from machine0, machine1" in out
    finally:
        server.stop()


def test_show_results_refuses_a_database_that_is_not_there(tmp_path):
    with pytest.raises(SystemExit, match="no such database"):
        show_results(str(tmp_path / "nothing"), journal_dir=str(tmp_path / "journal"))


def test_a_world_the_simulator_refuses_stops_the_serial_run_with_one_line(tmp_path):
    # simple's two robots at one pose: the map check has nothing to say, the simulator refuses
    from bullet_floor_sim.paths import worlds_dir

    src = os.path.join(worlds_dir(), "simple")
    world = tmp_path / "simple" / "world.yaml"
    world.parent.mkdir()
    text = open(os.path.join(src, "world.yaml")).read()
    for name in os.listdir(src):
        if name != "world.yaml":
            os.symlink(os.path.join(src, name), str(world.parent / name))
    import yaml
    doc = yaml.safe_load(text)
    doc["robots"][1]["pose"] = list(doc["robots"][0]["pose"])
    world.write_text(yaml.safe_dump(doc))
    with pytest.raises(SystemExit) as stop:
        eval_worlds.run_tasks([(str(world), 1)], 1, workers=1)
    msg = str(stop.value.code)
    assert msg.startswith("eval_worlds: %s, seed 1: " % world) and "\n" not in msg
    assert "robot 'robot1' spawns overlapping robot 'robot2'" in msg
