"""The map page in a real browser: headless Chromium (Debian's ``chromium``, which
``.ci/run`` installs) driven by Playwright.

A ``gcs run --sim --web`` mission is watched while it flies, with a client that never
reads attached all along: what the page shows (the vehicles drawn, the coverage, each
vehicle's cell) is checked against the station's own account, its log and its
report. Then ``gcs report --web`` replays that log and the slider is moved. The
screenshots are kept in ``test-artifacts/`` (or ``$GCS_TEST_ARTIFACTS``).
"""

from __future__ import annotations

import json
import os
import re
import select
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader

from tests.gcs.web.test_server import stuck_client
from tests.processes import ctrl_c, gcs_process

CHROMIUM = (
    os.environ.get("CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
)
#: As the machine's own check runs it: no sandbox as root, and no calls home.
FLAGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
REPO = Path(__file__).resolve().parents[3]
ARTIFACTS = Path(os.environ.get("GCS_TEST_ARTIFACTS", REPO / "test-artifacts"))
DEMO = REPO / "missions" / "demo.yaml"

pytestmark = [
    pytest.mark.timeout(240),
    pytest.mark.skipif(CHROMIUM is None, reason="no chromium here (.ci/run installs Debian's)"),
]


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    sync_api = pytest.importorskip("playwright.sync_api")
    with sync_api.sync_playwright() as playwright:
        chromium = playwright.chromium.launch(executable_path=CHROMIUM, args=FLAGS)
        try:
            yield chromium
        finally:
            chromium.close()


def page_address(process: subprocess.Popen[str], timeout_s: float = 60.0) -> str:
    """The page's address, from the line the command prints on stderr."""
    assert process.stderr is not None
    seen: list[str] = []
    fd = process.stderr.fileno()
    while True:
        ready, _, _ = select.select([fd], [], [], timeout_s)
        assert ready, f"no page address within {timeout_s} s: {seen}"
        line = process.stderr.readline()
        assert line, f"the command ended: {seen}"
        seen.append(line)
        found = re.search(r"map page at (http://\S+)", line)
        if found:
            return found.group(1)


def shown(page: Any) -> dict[str, Any]:
    """What the page shows, as it says in its body's data attributes and markers."""
    data = page.evaluate("({...document.body.dataset})")
    markers = "[...document.querySelectorAll('.vehicle-marker')]"
    cells = page.evaluate(f"{markers}.map(m => [m.dataset.sysid, m.dataset.cell])")
    data["cells"] = {int(sysid): cell for sysid, cell in cells}
    return data


def logged(path: Path) -> tuple[dict[float, int], dict[int, list[int]]]:
    """From the station's log: covered cells by the mission time of each progress, and
    each vehicle's last logged cell."""
    progress: dict[float, int] = {}
    cells: dict[int, list[int]] = {}
    with open(path, "rb") as handle:
        for _schema, channel, message in make_reader(handle).iter_messages():
            if channel.topic == "/run/progress":
                data = json.loads(message.data)
                progress[data["t_s"]] = data["covered"]
            elif channel.topic.endswith("/status"):
                data = json.loads(message.data)
                cells[data["sysid"]] = data["cell"]
    return progress, cells


@pytest.fixture(scope="module")
def watched(tmp_path_factory: pytest.TempPathFactory, browser: Any) -> dict[str, Any]:
    """The demo mission flown with the page open (and a stuck client), watched to its end."""
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    out = tmp_path_factory.mktemp("web-run")
    args = [
        "run",
        str(DEMO),
        "--sim",
        "--speedup",
        "40",
        "--web",
        "0",
        "--quiet",
        "--out",
        str(out),
    ]
    with gcs_process(*args) as process:
        url = page_address(process)
        stuck = stuck_client(int(url.rsplit(":", 1)[1].split("/")[0]))
        page = browser.new_page(viewport={"width": 1280, "height": 860})
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(url)
        page.wait_for_function(
            "Number(document.body.dataset.covered) > 100 && document.body.dataset.vehicles === '5'",
            timeout=90_000,
        )
        during = shown(page)
        page.screenshot(path=ARTIFACTS / "web-live-during.png")
        _, stderr = process.communicate(timeout=180)
        stuck.close()
        # The station is gone; the page keeps the end of the mission it was sent.
        page.wait_for_function("document.getElementById('source').textContent === 'ENDED'")
        after = shown(page)
        page.screenshot(path=ARTIFACTS / "web-live-end.png")
        page.close()
    return {
        "code": process.returncode,
        "stderr": stderr,
        "out": out,
        "during": during,
        "after": after,
        "errors": errors,
    }


def test_the_live_page_shows_what_the_station_knows(watched: dict[str, Any]) -> None:
    assert watched["code"] == 0, watched["stderr"]
    assert watched["errors"] == []
    progress, cells = logged(watched["out"] / "mission.mcap")
    during = watched["during"]
    # Mid-mission: the coverage shown is the station's at the same mission time.
    assert progress[float(during["progressT"])] == int(during["covered"])
    assert int(during["vehicles"]) == 5 == len(cells)
    # At the end: the report's coverage, and every vehicle where the log last put it.
    report = json.loads((watched["out"] / "report.json").read_text())
    after = watched["after"]
    assert float(after["coveragePct"]) == pytest.approx(report["coverage_pct"], abs=1e-3)
    assert int(after["covered"]) == report["free_cells"]
    assert after["cells"] == {sysid: ",".join(map(str, c)) for sysid, c in cells.items()}


def test_the_replay_follows_its_slider(watched: dict[str, Any], browser: Any) -> None:
    log = watched["out"] / "mission.mcap"
    progress, _ = logged(log)
    args = ["report", str(log), "--out", str(watched["out"] / "again"), "--web", "0", "--quiet"]
    with gcs_process(*args) as process:
        url = page_address(process)
        page = browser.new_page(viewport={"width": 1280, "height": 860})
        page.goto(url)
        page.wait_for_function("document.body.dataset.ready === 'yes'")
        end = shown(page)
        assert float(end["coveragePct"]) == pytest.approx(100.0)
        # Moved to the middle of the mission, the page shows the log's progress then.
        middle = round(max(progress) / 2, 1)
        page.locator("#slider").fill(str(middle))
        page.wait_for_function(f"Number(document.body.dataset.t) === {middle}")
        at = shown(page)
        page.screenshot(path=ARTIFACTS / "web-replay-middle.png")
        before = max(t for t in progress if t <= middle)
        assert int(at["covered"]) == progress[before] < int(end["covered"])
        assert int(at["vehicles"]) == 5
        page.close()
        ctrl_c(process)
