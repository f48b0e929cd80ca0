"""`rt watch` in a real headless browser: Debian's chromium, driven by playwright (pointed at the
system browser: nothing is downloaded at run time).

Skipped, saying why, where the browser is missing: `apt-get install chromium` installs it.
Playwright comes with the test extra, so without it the install is broken and the file fails to
import rather than skipping. RT_SCREENSHOT=path keeps a
screenshot of the page showing an image, and one showing an error (path with -error).
"""

import os
import re
import shutil
import time
from pathlib import Path

import pytest
from playwright import sync_api

from rt.watch import Watch, WatchOptions

from .test_watch import LIB, SCENE, save

BROWSER = next((shutil.which(name) for name in ("chromium", "chromium-browser") if shutil.which(name)), None)

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(BROWSER is None, reason="no system chromium: install it with `apt-get install chromium`"),
]


def test_the_page_shows_the_image_follows_saves_and_shows_errors_with_their_line(tmp_path):
    (tmp_path / "scene.yaml").write_text(SCENE.replace("width: 64", "width: 240").replace("samples_per_pixel: 8", "samples_per_pixel: 32"))
    (tmp_path / "lib.yaml").write_text(LIB)
    watch = Watch(WatchOptions(tmp_path / "scene.yaml"), port=0, say=lambda m: None).start()
    shots = os.environ.get("RT_SCREENSHOT")
    try:
        with sync_api.sync_playwright() as p:
            browser = p.chromium.launch(executable_path=BROWSER, args=["--no-sandbox"])
            page = browser.new_page(viewport={"width": 520, "height": 420})
            page.goto(watch.url)
            # An image, refined to the file's 32 samples.
            # (Selectors and attribute reads, not wait_for_function: the page's Content-Security-Policy,
            # kept on here, forbids the string evaluation that one uses.)
            page.wait_for_selector('#image[data-samples="32"]', timeout=120_000)
            assert page.eval_on_selector("#image", "i => i.naturalWidth") == 240
            assert "32 of 32 spp" in page.text_content("#status") and "noise" in page.text_content("#status")
            first = page.eval_on_selector("#image", "i => i.src")
            if shots:
                page.screenshot(path=shots)

            # A save: the image changes.
            save(tmp_path / "lib.yaml", LIB.replace("[0.8, 0.2, 0.2]", "[0.2, 0.2, 0.8]"))
            page.wait_for_selector(f'#image:not([src="{first}"])', timeout=60_000)
            generation = int(page.get_attribute("#image", "data-generation"))

            # A broken save: the error with its place and line; the image stays.
            save(tmp_path / "scene.yaml", (tmp_path / "scene.yaml").read_text().replace("radius: 0.5", "radius: -0.5"))
            page.wait_for_selector("#problems:not([hidden])", timeout=60_000)
            text = page.text_content("#problems")
            assert re.search(r"scene.yaml:6:49: error: shapes\[1\].radius: a sphere.s radius must be > 0", text)
            assert "{type: sphere, center: [0, 0.5, 0], radius: -0.5, material: ball}" in text
            assert page.is_visible("#image")
            if shots:
                page.screenshot(path=str(Path(shots).with_stem(Path(shots).stem + "-error")))

            # Mended: the errors go and a new image comes.
            save(tmp_path / "scene.yaml", (tmp_path / "scene.yaml").read_text().replace("radius: -0.5", "radius: 0.6"))
            page.wait_for_selector("#problems", state="hidden", timeout=60_000)
            deadline = time.monotonic() + 60
            while int(page.get_attribute("#image", "data-generation")) <= generation:
                assert time.monotonic() < deadline, "no new image after the mend"
                page.wait_for_timeout(50)
            browser.close()
    finally:
        watch.close()
