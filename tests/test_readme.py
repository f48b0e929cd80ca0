"""The README, run the way a newcomer runs it; and the batch behaviour it describes.

`test_the_readme_runs_as_shown` installs the project as the README's set-up command does and
then runs every marked block of README.md, in the README's order:

- A copy of the checkout's tracked files (`git ls-files`) in a temporary folder is the checkout:
  nothing is written into the real one (no build/, no egg-info, no images).
- The set-up command (between the render-command markers) runs there as written: a fresh
  virtual environment, `pip install .`, no extras. The checkout's own .venv is never used. Every
  shipped scene is then validated and rendered on that plain install.
- Each later block runs with that environment active (PATH and VIRTUAL_ENV, as
  `. .venv/bin/activate` sets them), from the copy's root, in order, so an extra is there only
  once a block has installed it as the README says (`pip install '.[exr]'`).
- `sh` blocks run line by line with bash. A comment line right after a command is what that
  command prints as its error: the command must exit 1 and print it. A line ending in `&` is a
  server: it is started, waited for until it is ready, and stopped when the test ends.
- `yaml` blocks are written to the file their `# NAME.yaml` comment names; `python` blocks run
  with the environment's python.
- The test-command block is what CI runs (tests/test_project.py checks that), so it is not run
  again from inside the suite.

The README's commands are run as written, with two changes and no others: SCALE is appended to
every `rt render` and `rt watch` (the last of a repeated option wins, so a command renders a
16-pixel-wide image at 2 samples per pixel however large it asks for), and a Dask scheduler's
port, 8786, becomes a free one (`rt watch` gets `--port 0`, any free port). The user's comforts
are left out: Numba's cache starts cold in a temporary folder (one for the whole test, shared by
its commands as one machine's are), no Dask client or configuration, no PYTHONPATH.

Images written by a command are checked for their values: readable, finite, non-negative, not
black (every shipped scene is lit), and 16 pixels wide where `rt render` or `rt watch` wrote them.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from rt.cli import app
from tests.test_batch import three_scenes
from tests.test_project import ROOT

SCALE = ["--spp", "2", "--width", "16"]
SCALED_WIDTH = 16
SCHEDULER_PORT = "8786"
# The line a server prints once it serves, by the command that starts it.
READY = {"dask scheduler": "Scheduler at:", "dask worker": "Registered to:", "rt watch": "rt watch: http://"}
# Markers whose blocks this test does not run, and why.
NOT_RUN = {"test-command": "CI runs it (.ci/run); tests/test_project.py checks that it is the README's"}
IMAGE_SUFFIXES = (".png", ".exr", ".pfm")


@dataclass
class Block:
    marker: str
    language: str
    text: str


def marked_blocks(readme: str) -> list[Block]:
    """Every fenced block between a `<!-- NAME -->` and its `<!-- /NAME -->`, in the README's order."""
    blocks = []
    for match in re.finditer(r"<!-- ([a-z-]+) -->\n(.*?)<!-- /\1 -->", readme, re.S):
        for fence in re.finditer(r"```(\w+)\n(.*?)```", match.group(2), re.S):
            blocks.append(Block(match.group(1), fence.group(1), fence.group(2)))
    return blocks


def test_every_command_and_code_block_of_the_readme_is_marked():
    """A block of commands, a scene or code outside markers would escape the test below."""
    readme = (ROOT / "README.md").read_text()
    marked = {block.text for block in marked_blocks(readme)}
    shown = re.findall(r"```(\w+)\n(.*?)```", readme, re.S)
    assert shown, "README.md shows no code blocks"
    unmarked = [text.splitlines()[0] for language, text in shown if text not in marked]
    assert not unmarked, f"README blocks outside markers, which test_readme would not run: {unmarked}"


def command_line(line: str) -> str:
    """A README command as the test runs it: its comment dropped, SCALE appended to `rt render`
    and `rt watch` (which must come last on the line), the scheduler's port made free."""
    line = re.sub(r"\s+#\s.*$", "", line).strip()
    for program, extra in (("rt render ", SCALE), ("rt watch ", [*SCALE, "--port", "0"])):
        if program in line:
            last = re.split(r"&&|\|\|?|;", line.rstrip("& "))[-1]
            assert program in last, f"README: put {program.strip()} last on the line so that it can be scaled: {line}"
            background = line.endswith("&")
            line = line.rstrip("& ") + " " + " ".join(extra) + (" &" if background else "")
    return line


@dataclass
class Session:
    """The copied checkout, the environment its commands run in, and what they started."""

    checkout: Path
    env: dict
    port: str
    servers: list = field(default_factory=list)
    timings: list = field(default_factory=list)

    def run(self, line: str, expect_error: str | None = None, timeout: float = 600) -> subprocess.CompletedProcess:
        command = command_line(line).replace(SCHEDULER_PORT, self.port)
        if command.endswith("&"):
            return self.start(command.rstrip("& "))
        before = images(self.checkout)
        started = time.perf_counter()
        result = subprocess.run(["bash", "-c", command], cwd=self.checkout, env=self.env, capture_output=True, text=True,
                                timeout=timeout, stdin=subprocess.DEVNULL)
        self.timings.append((time.perf_counter() - started, command))
        said = f"README command: {command}\nexit {result.returncode}\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}"
        assert "Traceback" not in result.stderr, said
        if expect_error is None:
            assert result.returncode == 0, said
        else:
            assert result.returncode == 1 and expect_error in result.stderr, said
        for path in changed_images(before, images(self.checkout)):
            check_image(path, SCALED_WIDTH if "rt render " in command else None)
        return result

    def start(self, command: str) -> None:
        """Start a server the README puts in the background; return once it says it is ready."""
        (ready,) = [text for program, text in READY.items() if command.startswith(program) or f" {program} " in command]
        log = self.checkout / f".server-{len(self.servers)}.log"
        with open(log, "w") as out:
            process = subprocess.Popen(["bash", "-c", f"exec {command}"], cwd=self.checkout, env=self.env, stdout=out,
                                       stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, start_new_session=True)
        self.servers.append(process)
        started = time.monotonic()
        while ready not in log.read_text():
            assert process.poll() is None, f"README server {command} ended: {log.read_text()[-3000:]}"
            assert time.monotonic() < started + 120, f"README server {command} not ready in 120 s: {log.read_text()[-3000:]}"
            time.sleep(0.2)
        self.timings.append((time.monotonic() - started, f"{command} (until ready)"))
        return process, log

    def stop_servers(self) -> None:
        for process in reversed(self.servers):
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGTERM)
        for process in self.servers:
            try:
                process.wait(20)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait(10)


def images(folder: Path) -> dict:
    """Image files under `folder` (not the environment's) and when each was last written."""
    found = {}
    for path in folder.rglob("*"):
        if path.suffix.lower() in IMAGE_SUFFIXES and ".venv" not in path.parts and "build" not in path.parts:
            found[path] = path.stat().st_mtime_ns
    return found


def changed_images(before: dict, after: dict) -> list:
    return [path for path, written in after.items() if before.get(path) != written]


def check_image(path: Path, width: int | None) -> None:
    """A written image holds a picture: readable, finite, non-negative, not black, `width` wide."""
    if path.suffix.lower() == ".png":
        from PIL import Image

        with Image.open(path) as image:
            pixels = np.asarray(image.convert("RGB"), np.float64)
    else:
        from scenefmt.hdr_files import read_hdr

        pixels = read_hdr(path, 1 << 24)
    assert np.isfinite(pixels).all() and (pixels >= 0).all(), f"{path}: values not finite or negative"
    assert (pixels.max(axis=2) > 0).sum() >= 3, f"{path}: black"
    if width is not None:
        assert pixels.shape[1] == width, f"{path}: {pixels.shape[1]} wide, not {width}"


def free_port() -> str:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return str(sock.getsockname()[1])


def copy_checkout(to: Path) -> Path:
    """The checkout's tracked files, as they are in the work tree, copied to `to`."""
    listed = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, text=True)
    if listed.returncode != 0:  # an unpacked archive: the tree less what a build or a run leaves
        shutil.copytree(ROOT, to, ignore=shutil.ignore_patterns(".git", ".venv", "build", "*.egg-info", "__pycache__",
                                                                 ".pytest_cache"))
        return to
    for name in filter(None, listed.stdout.split("\0")):
        source = ROOT / name
        if source.is_file():  # a tracked file deleted in the work tree is not copied
            (to / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, to / name)
    return to


def user_environment(cache: Path) -> dict:
    """The calling environment less what a newcomer would not have: the checkout's .venv on the
    PATH, PYTHONPATH, a warm Numba cache, Dask configuration."""
    env = {key: value for key, value in os.environ.items()
           if key not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV") and not key.startswith(("NUMBA_", "DASK_"))}
    env["PATH"] = os.pathsep.join(p for p in env.get("PATH", "").split(os.pathsep) if p and not p.startswith(str(ROOT)))
    env["NUMBA_CACHE_DIR"] = str(cache)
    return env


def activate(env: dict, venv: Path) -> dict:
    """`env` as `. .venv/bin/activate` leaves it."""
    return {**env, "VIRTUAL_ENV": str(venv), "PATH": f"{venv / 'bin'}{os.pathsep}{env['PATH']}"}


def yaml_name(text: str) -> str:
    names = [m.group(1) for m in re.finditer(r"^# ([\w./-]+\.ya?ml)\b", text, re.M)]
    assert names, f"README: a yaml block needs a '# NAME.yaml' comment naming its file:\n{text[:200]}"
    return names[0]


def shipped_scenes(checkout: Path) -> list[str]:
    return sorted(str(p.relative_to(checkout)) for p in (checkout / "scenes").iterdir() if p.suffix in (".yaml", ".json"))


def run_sh(session: Session, block: Block) -> None:
    lines = [line for line in block.text.splitlines() if line.strip()]
    for i, line in enumerate(lines):
        if line.lstrip().startswith("#"):
            continue  # the previous command's expected error, checked with it
        following = lines[i + 1] if i + 1 < len(lines) else ""
        expected = following.lstrip()[2:].strip() if following.lstrip().startswith("# ") else None
        if line.lstrip().startswith("rt watch "):
            watch(session, line)
        else:
            session.run(line, expect_error=expected)


def watch(session: Session, line: str) -> None:
    """A README `rt watch`: serve, show a picture of the scene, stop on Ctrl-C with status 0."""
    process, log = session.start(command_line(line).rstrip("& "))
    url = re.search(r"rt watch: (http://\S+/)", log.read_text()).group(1)
    deadline = time.monotonic() + 120
    while True:
        try:
            with urllib.request.urlopen(url + "image.png", timeout=10) as response:
                png = response.read()
            break
        except OSError:  # 404 until the first pass is drawn
            assert time.monotonic() < deadline, f"{line}: no image in 120 s: {log.read_text()[-2000:]}"
            time.sleep(0.2)
    (session.checkout / "watch.png").write_bytes(png)
    check_image(session.checkout / "watch.png", None)
    (session.checkout / "watch.png").unlink()
    os.killpg(process.pid, signal.SIGINT)
    assert process.wait(60) == 0, log.read_text()[-2000:]
    assert "stopped" in log.read_text() and "Traceback" not in log.read_text()


def run_readme(work: Path) -> "ReadmeRun":
    """Install as the README's set-up does and run every marked block, in `work`; raises
    AssertionError on what fails. Returns what it ran and the files it left."""
    readme = (ROOT / "README.md").read_text()
    blocks = marked_blocks(readme)
    checkout = copy_checkout(work / "checkout")
    env = user_environment(work / "numba-cache")
    session = Session(checkout, env, free_port())
    started = time.perf_counter()
    try:
        (setup,) = [b for b in blocks if b.marker == "render-command"]
        (line,) = [line for line in setup.text.splitlines() if line.strip()]
        first = session.run(line)  # installs without extras and renders: the Numba cache is cold here
        compiled = re.search(r"(\d[\dhms.]*) in all\)", first.stdout)  # "(+ 26.2s compiling; 28.4s in all)"
        session.timings.append((0.0, f"of which the first rt render, a cold compile: {compiled and compiled.group(1)}"))
        session.env = activate(env, checkout / ".venv")
        assert "openexr" not in session.run("pip list").stdout.lower()

        # Every shipped scene on the plain install: validated, then rendered to a new folder.
        scenes = " ".join(shipped_scenes(checkout))
        session.run(f"rt validate {scenes}")
        session.run(f"rt render {scenes} -o plain/new")
        rendered = sorted(p.stem for p in (checkout / "plain" / "new").glob("*.png"))
        assert rendered == sorted(Path(s).stem for s in scenes.split())

        for block in blocks:
            if block.marker in ("render-command", *NOT_RUN):
                continue
            if block.language == "yaml":
                (checkout / yaml_name(block.text)).parent.mkdir(parents=True, exist_ok=True)
                (checkout / yaml_name(block.text)).write_text(block.text)
            elif block.language == "python":
                # From the checkout's root, as the README's paths are, but as a script kept outside
                # it: a script in the root would import the source tree beside it, not the package
                # the set-up installed (and compile the kernels again: Numba keys its cache by the
                # source's path).
                script = work / f"{block.marker}.py"
                script.write_text(block.text)
                session.run(f"python {script}")
            else:
                assert block.language == "sh", f"README: block of {block.language} between {block.marker} markers"
                run_sh(session, block)
    finally:
        session.stop_servers()
        session.timings.insert(0, (time.perf_counter() - started, "the README test in all"))

    return ReadmeRun(
        timings=[f"{seconds:6.1f} s  {command[:110]}" for seconds, command in session.timings],
        commands=[command for _, command in session.timings],
        shipped=shipped_scenes(checkout),
        files=sorted(str(p.relative_to(checkout)) for p in checkout.rglob("*")
                     if p.is_file() and ".venv" not in p.parts and p.suffix in (".exr", ".png", ".yaml", ".pfm")),
    )


@dataclass
class ReadmeRun:
    """What `run_readme` saw: each command's time, the commands, the shipped scenes, the files left."""

    timings: list
    commands: list
    shipped: list
    files: list


class BackgroundRun:
    """`run_readme` in a thread of its own, started when the session's tests are collected
    (tests/conftest.py) and joined by the test. Its work is mostly waiting on one process at a
    time (pip, a single-threaded compile, tiny renders), so on CI's two cores it overlaps the
    rest of the suite instead of adding its two minutes to it. Nothing is shared with the other
    tests: its own temporary folder, cache, ports and environment."""

    def __init__(self):
        import tempfile
        import threading

        self.work = Path(tempfile.mkdtemp(prefix="rt-readme-"))
        self.outcome: tuple = ("not finished", None)
        self.thread = threading.Thread(target=self.main, name="readme", daemon=True)
        self.thread.start()

    def main(self) -> None:
        try:
            self.outcome = ("passed", run_readme(self.work))
        except BaseException as exc:  # noqa: BLE001 - re-raised in the test that joins it
            self.outcome = ("failed", exc)

    def result(self, timeout: float) -> "ReadmeRun":
        self.thread.join(timeout)
        try:
            assert not self.thread.is_alive(), f"the README run did not finish in {timeout:.0f} s"
            status, value = self.outcome
            if status == "failed":
                raise value
            return value
        finally:
            if not self.thread.is_alive():
                shutil.rmtree(self.work, ignore_errors=True)


background: BackgroundRun | None = None


def start_in_background() -> None:
    global background
    if background is None:
        background = BackgroundRun()


@pytest.mark.slow
def test_the_readme_runs_as_shown(tmp_path):
    run = background.result(timeout=1800) if background is not None else run_readme(tmp_path)
    print("\nREADME test:\n" + "\n".join(run.timings))
    ran = " ".join(run.commands)
    # The commands the issue names ran, as the README writes them.
    for wanted in ("pip install .", "pip install '.[exr]'", "pip install '.[cluster]'", "--cluster local",
                   "dask scheduler", "dask worker", "--cluster tcp://127.0.0.1:", "rt watch ", "rt render - ",
                   "-o renders/", "rt validate scenes/*.yaml"):
        assert wanted in ran, f"the README test did not run {wanted!r}"
    # What the blocks promise, beyond running: every shipped scene rendered on the plain install,
    # the batch made its new folder with linear images, the Python blocks wrote their files.
    assert run.shipped == shipped_scenes(ROOT)  # every scene in scenes/, none missed by the copy
    for scene in run.shipped:
        assert f"plain/new/{Path(scene).stem}.png" in run.files, scene
        if scene.endswith(".yaml"):
            assert f"renders/{Path(scene).stem}.exr" in run.files, scene
    assert "my_scene.yaml" in run.files and "scene.exr" in run.files
    assert not (ROOT / "renders").exists() and not (ROOT / "my_scene.yaml").exists()


# The batch (`rt render a.yaml b.yaml ...`): a new -o folder, and a failure of any kind is one line.

runner = CliRunner()


@pytest.mark.slow
def test_a_batch_makes_its_output_folder_and_its_parents(tmp_path):
    scenes = three_scenes(tmp_path)
    out = tmp_path / "renders" / "today"
    result = subprocess.run([sys.executable, "-m", "rt", "render", *scenes, "-o", str(out), "--spp", "2"],
                            capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert result.returncode == 0, result.stderr
    for name in ("a", "b", "c"):
        check_image(out / f"{name}.png", 16)


def test_a_batch_refuses_an_output_that_is_a_file_or_cannot_be_made(tmp_path, monkeypatch):
    a, b, _ = three_scenes(tmp_path)
    (tmp_path / "taken").write_text("mine")
    result = runner.invoke(app, ["render", a, b, "-o", str(tmp_path / "taken")])
    assert result.exit_code == 1 and "with several scenes, -o names the folder" in result.stderr
    assert (tmp_path / "taken").read_text() == "mine"
    result = runner.invoke(app, ["render", a, b, "-o", str(tmp_path / "taken" / "below")])
    assert result.exit_code == 1 and "cannot create the folder" in result.stderr
    assert result.stderr.count("\n") == 1
    # A refused batch makes no folder.
    result = runner.invoke(app, ["render", a, b, "-o", str(tmp_path / "new"), "--hdr", "out.exr"])
    assert result.exit_code == 1 and not (tmp_path / "new").exists()


def test_a_batch_to_exr_without_openexr_is_refused_once_before_rendering(tmp_path, monkeypatch):
    import scenefmt.hdr_files

    a, b, c = three_scenes(tmp_path)
    monkeypatch.setattr(scenefmt.hdr_files, "exr_available", lambda: False)
    result = runner.invoke(app, ["render", a, b, c, "-o", str(tmp_path / "out"), "--hdr", "exr"])
    assert result.exit_code == 1
    assert result.stderr.count("needs the openexr package") == 1 and "[1/3]" not in result.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_an_unexpected_failure_of_one_scene_is_one_line_and_the_others_render(tmp_path, monkeypatch):
    import rt.render_job

    a, b, c = three_scenes(tmp_path)
    real_prepare = rt.render_job.prepare

    def prepare(opts):
        if opts.scene.name == "b.yaml":
            raise RuntimeError("the disk\nis full")
        return real_prepare(opts)

    monkeypatch.setattr(rt.render_job, "prepare", prepare)
    monkeypatch.chdir(tmp_path)
    result = runner.invoke(app, ["render", a, b, c, "--spp", "1"])
    assert result.exit_code == 1
    assert f"error: {b}: an unexpected failure (RuntimeError); the other scenes go on (please report this scene)\n" in result.stderr
    assert "the disk" not in result.stderr  # an unforeseen exception's text is not shown: it may hold anything
    assert "Traceback" not in result.stderr
    assert result.stderr.rstrip().endswith(f"error: 1 of 3 scenes failed: {b}")
    assert sorted(p.name for p in tmp_path.glob("*.png")) == ["a.png", "c.png"]


def test_a_ply_scene_without_plyfile_is_a_clean_error():
    """plyfile is a dependency; an environment that lacks it anyway gets an error, not a traceback."""
    code = ("import sys; sys.modules['plyfile'] = None; sys.argv = ['rt', 'validate', 'scenes/cornell_knot.yaml']; "
            "from rt.__main__ import run; run()")
    result = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert result.returncode == 1, result.stderr
    assert "Traceback" not in result.stderr
    assert "torus_knot.ply': reading PLY needs the plyfile package, which is not installed: pip install plyfile" in result.stderr


def test_plyfile_is_a_dependency_of_the_plain_install():
    """A shipped scene (cornell_knot) is a PLY mesh, so `pip install .` must bring plyfile."""
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert any(dep.startswith("plyfile") for dep in project["dependencies"])
    assert "meshes" not in project["optional-dependencies"]


def test_the_readme_error_in_an_included_file_is_what_rt_prints(tmp_path, monkeypatch):
    """The include example's files, with `glass` misspelt as the README says, give its error line."""
    readme = (ROOT / "README.md").read_text()
    files = [b for b in marked_blocks(readme) if b.marker == "include-files"]
    assert len(files) == 3
    for block in files:
        path = tmp_path / yaml_name(block.text)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(block.text.replace("material: glass}", "material: glas}"))
    shown = re.search(r"```\n(furniture\.yaml:\d+:\d+: error: .*)\n```", readme).group(1)
    monkeypatch.chdir(tmp_path)
    result = runner.invoke(app, ["validate", "room.yaml"])
    assert result.exit_code == 1 and shown in result.stderr.splitlines()
