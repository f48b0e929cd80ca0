"""Project set-up: CI runs the README's test command, and the README's commands exist."""

import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def block(marker: str) -> list[str]:
    text = (ROOT / "README.md").read_text()
    inside = text.split(f"<!-- {marker} -->", 1)[1].split(f"<!-- /{marker} -->", 1)[0]
    return [line for line in inside.splitlines() if line.strip() and not line.startswith("```")]


def test_ci_runs_exactly_the_readme_test_command():
    (command,) = block("test-command")
    extracted = subprocess.run(
        ["bash", "-c", "sed -n '/<!-- test-command -->/,/<!-- \\/test-command -->/p' README.md | grep -v -e '^<!--' -e '^```'"],
        cwd=ROOT, capture_output=True, text=True, check=True,
    ).stdout.strip()
    assert extracted == command
    assert "pytest" in command and "pip install" in command
    assert "README.md" in (ROOT / ".ci" / "run").read_text()


def test_readme_render_command_names_a_shipped_scene():
    (command,) = block("render-command")
    scene = command.split("rt render ", 1)[1].split()[0]
    assert (ROOT / scene).is_file()
