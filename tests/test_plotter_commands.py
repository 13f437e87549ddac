"""The plotter command's table of subcommands: its own, and those other
installed packages add through the entry point group plotter.commands."""
import io
import subprocess
from pathlib import Path

import pytest

from plotter_bridge.cli import main as cli
from plotter_bridge.cli.command import Command

REPO = Path(__file__).resolve().parent.parent


class FakeEntryPoint:
    def __init__(self, name, value, load):
        self.name, self.value, self._load = name, value, load

    def load(self):
        return self._load()


def _broken():
    raise ImportError("no module named vpype")


def test_commands_of_other_packages_join_the_table_and_a_broken_one_is_reported(monkeypatch):
    calls = []
    hello = Command("hello", "say hello", lambda p: p.add_argument("--name"),
                    lambda args: calls.append(args.name) or 0)
    clash = Command("check", "not the real check", lambda p: None, lambda args: 99)
    points = [FakeEntryPoint("greet", "greet.commands:COMMANDS", lambda: (hello, clash)),
              FakeEntryPoint("broken", "broken.commands:COMMANDS", _broken)]
    monkeypatch.setattr(cli, "entry_points", lambda group: points if group == cli.ENTRY_POINT_GROUP else [])
    err = io.StringIO()
    found = cli.installed_commands(err)
    assert list(found) == ["hello"]                 # check stays this package's own
    assert "broken.commands:COMMANDS" in err.getvalue() and "vpype" in err.getvalue()
    monkeypatch.setattr(cli, "installed_commands", lambda: found)
    assert cli.main(["hello", "--name", "pen"]) == 0 and calls == ["pen"]
    assert cli.all_commands()["check"] is cli.COMMANDS["check"]


def test_without_extensions_the_own_commands_remain(monkeypatch):
    monkeypatch.setattr(cli, "entry_points", lambda group: [])
    assert list(cli.all_commands()) == ["check", "stream", "resume", "jobs", "watch", "state", "hold", "estop",
                                        "reset", "set-origin", "home", "follow"]


@pytest.mark.ros
def test_installed_plotter_lists_the_shapes_commands():
    plotter = REPO / ".venv" / "bin" / "plotter"
    r = subprocess.run([str(plotter), "--help"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    for name in ("check", "stream", "resume", "jobs", "watch", "follow", "draw", "svg", "text"):
        assert f"    {name} " in r.stdout, (name, r.stdout)
    assert r.stderr == ""
