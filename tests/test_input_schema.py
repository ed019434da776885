"""Every value from outside passes one schema (``sim.model.schema``): scene files, ``--set`` and the
page.  Each refusal is one line (CLI exit 2), never a traceback or a warning flood; long commands
share one planned-work limit; names reach the terminal as text."""

from __future__ import annotations

import os
import warnings

import pytest

from app.cli import main
from app.web.inputs import InputRefused, choice, number, whole_number
from sim.model import schema


def scene(tmp_path, body: str, model: str = "nx = 3\nny = 2\n", name: str = "s"):
    path = tmp_path / f"{name}.toml"
    path.write_text(f"format = 1\n{body}\n[model]\n{model}", encoding="utf-8")
    return path


def one_line_refusal(capsys, arguments: list[str]) -> str:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        code = main(arguments)
    captured = capsys.readouterr()
    assert code == 2, captured
    assert captured.err.startswith("error: ") and captured.err.count("\n") == 1, captured.err
    # the command's own warnings: a page server left by an earlier test in this process may
    # warn from its threads meanwhile (the command never starts one)
    own = [warning for warning in caught if f"{os.sep}viser{os.sep}" not in warning.filename]
    assert not own, [str(warning.message) for warning in own]
    return captured.err


def test_a_deeply_nested_scene_file_is_one_line(tmp_path, capsys):
    deep = "[" * 2000 + "]" * 2000
    path = scene(tmp_path, 'name = "deep"', f"nx = 3\nny = 2\n[initial]\ndisplacements = {deep}\n")
    assert path.stat().st_size < 5000
    assert "nested" in one_line_refusal(capsys, ["run", str(path), "--steps", "1"])


@pytest.mark.parametrize("setting", ["spacing=1e200", "damping=1e200", "stiffness=1e300",
                                     "mass=1e-300", "gravity=1e300", "drag=1e200"])
def test_huge_parameters_are_one_line_without_warnings(capsys, setting):
    one_line_refusal(capsys, ["run", "grid", "--set", setting, "--steps", "1"])


@pytest.mark.parametrize("body, model, words", [
    ('name = "s"', 'nx = "12"\nny = 2\n', "nx must be a whole number"),
    ('name = "s"', "nx = 12.5\nny = 2\n", "nx must be a whole number"),
    ('name = "s"', 'nx = 3\nny = 2\nstiffness = "35"\n', "stiffness must be a number"),
    ('name = "s"', "nx = 3\nny = 2\nlinear = 1\n", "linear must be true or false"),
    ('name = "s"\ndt = "0.01"', "nx = 3\nny = 2\n", "dt must be a number"),
    ('name = "s"\nduration = 1e300', "nx = 3\nny = 2\n", "duration must be in"),
    ("name = 5", "nx = 3\nny = 2\n", "name must be text"),
    ('name = "s"', "nx = 12\nny = 2\n[initial]\ndisplacements = [[5.7, 0.1, 0.0]]\n",
     "index must be a whole number"),
    ('name = "s"', 'nx = 12\nny = 2\n[initial]\ndisplacements = [[5, "0.1", 0.0]]\n',
     "displacement must be a number"),
])
def test_scene_file_types_are_exact(tmp_path, capsys, body, model, words):
    path = scene(tmp_path, body, model)
    assert words in one_line_refusal(capsys, ["run", str(path), "--steps", "1"])


def test_the_page_uses_the_same_checks():
    for bad in ("0.5", None, True, [1.0], float("nan")):
        with pytest.raises(InputRefused):
            number(bad, "dt", 0.0, 1.0)
    with pytest.raises(InputRefused, match="whole number"):
        whole_number(2.5, "nx", 1, 100)
    with pytest.raises(InputRefused):
        choice("<b>rk4</b>", "Method", ("rk4", "verlet"))
    assert issubclass(InputRefused, schema.Refused)
    assert number(3, "dt", 0.0, 10.0) == 3.0 and whole_number(4.0, "nx", 1, 9) == 4


@pytest.mark.parametrize("arguments", [
    ["movie", "grid", "--duration", "1e12", "-o", "m.gif"],
    ["bench", "--seconds", "1e9"],
    ["run", "grid", "--duration", "1e12"],
])
def test_every_long_command_has_the_planned_work_limit(tmp_path, monkeypatch, capsys, arguments):
    monkeypatch.chdir(tmp_path)
    assert "limit" in one_line_refusal(capsys, arguments)


@pytest.mark.parametrize("parts", ["speed", "", "instruments,threads,x"])
def test_bench_refuses_parts_it_does_not_have(capsys, parts):
    with pytest.raises(SystemExit) as exit_:
        main(["bench", "--only", parts])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "integrators, threads, specialisation, instruments" in err


def test_a_scene_files_huge_duration_is_refused_before_a_movie(tmp_path, capsys):
    path = scene(tmp_path, 'name = "long"\nduration = 1e11')
    err = one_line_refusal(capsys, ["movie", str(path), "-o", str(tmp_path / "m.gif")])
    assert "limit" in err


def test_control_characters_in_names_are_escaped_on_the_terminal(tmp_path, capsys):
    path = scene(tmp_path, 'name = "\\u001b]0;owned\\u0007\\u001b[2Jx\\u202e"\nduration = 0.05')
    assert main(["run", str(path), "--steps", "2"]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\x07" not in out and "\u202e" not in out
    assert "\\x1b]0;owned\\x07" in out
    assert schema.printable("a\rb\x9bc") == "a\\x0db\\x9bc"
