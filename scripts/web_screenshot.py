#!/usr/bin/env python3
"""A picture of the web page after it drew the seed figures (docs/web_ui.png).

Starts the four nodes on the mock board and web_ui, each its own process,
opens the page in headless Chromium (Debian's chromium and chromium-driver:
`PLOTTER_BROWSER=1 bash scripts/setup.sh` installs them), draws each figure
by filling in the page's shape form and pressing Draw, waits for it, and
saves a screenshot of the page.  Run it after `source .venv/bin/activate &&
source ros_ws/install/setup.bash`.
"""
from __future__ import annotations

import argparse
import os
import random
import shutil
import socket
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))   # the node graph as processes
from node_processes import NodeProcess, PlotterGraph, params_file, wait_until  # noqa: E402
from plotter_shapes.geometry import SEED_FIGURES  # noqa: E402

CHROME_ARGS = ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
               "--disable-background-networking", "--disable-component-update", "--disable-sync",
               "--disable-dev-shm-usage", "--window-size=1400,1000")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="docs/web_ui.png", help="the screenshot (default docs/web_ui.png)")
    ap.add_argument("--figures", type=int, default=len(SEED_FIGURES), help="how many of the seed figures to draw")
    args = ap.parse_args()
    for exe in ("/usr/bin/chromium", "/usr/bin/chromedriver"):
        if not shutil.which(exe):
            print(f"{exe} is missing: PLOTTER_BROWSER=1 bash scripts/setup.sh installs it", file=sys.stderr)
            return 1
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.support.ui import Select

    domain = int(os.environ.get("ROS_DOMAIN_ID", random.randint(1, 100)))
    work = Path(tempfile.mkdtemp(prefix="plotter-web-"))
    graph = PlotterGraph(domain, work)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    ui = NodeProcess("plotter_web.web_ui_node", domain, ("-r", "__ns:=/plotter", "--params-file", params_file(),
                                                         "-p", f"port:={port}"))
    options = webdriver.ChromeOptions()
    options.binary_location = "/usr/bin/chromium"
    for a in CHROME_ARGS:
        options.add_argument(a)
    driver = None
    try:
        wait_until(lambda: "plotter page on" in ui.output(), 30, "the web server")
        driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)
        driver.get(f"http://127.0.0.1:{port}/")
        text = lambda element_id: driver.find_element("id", element_id).text  # noqa: E731
        wait_until(lambda: text("state") == "IDLE", 60, "IDLE on the page")
        for k, fig in enumerate(SEED_FIGURES[:args.figures]):
            Select(driver.find_element("id", "shape")).select_by_visible_text(fig["shape"])
            for field, value in (("shape-x", fig["x"]), ("shape-y", fig["y"]), ("shape-size", fig["size"]),
                                 ("shape-feed", 0)):
                el = driver.find_element("id", field)
                el.clear()
                el.send_keys(str(value))
            for box, want in (("shape-cw", fig.get("clockwise", False)), ("shape-reverse", fig.get("reverse", False))):
                el = driver.find_element("id", box)
                if el.is_selected() != bool(want):
                    el.click()
            count = driver.find_element("id", "job-count").get_attribute("textContent")
            driver.find_element("id", "draw").click()
            wait_until(lambda: driver.find_element("id", "job-count").get_attribute("textContent") != count, 30,
                       f"figure {k + 1} to be sent")
            try:
                wait_until(lambda: text("job-status") == "succeeded", 180, f"figure {k + 1} to be drawn")
            except TimeoutError:
                # What the page and the nodes said, for whoever reads the failure.
                print(f"page: state {text('state')!r}, job {text('job-status')!r}\n{graph.outputs()}\n"
                      f"web_ui:\n{ui.output()}", flush=True)
                raise
            print(f"drew {fig['shape']}{' reversed' if fig.get('reverse') else ''} through the page", flush=True)
        time.sleep(1.5)                       # the ink comes once a second
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        driver.save_screenshot(args.out)
        print(f"wrote {args.out}")
        return 0
    finally:
        if driver is not None:
            driver.quit()
        ui.interrupt()
        ui.close()
        graph.close()


if __name__ == "__main__":
    sys.exit(main())
