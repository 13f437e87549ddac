"""The web page, driven in headless Chromium (Debian's chromium and
chromium-driver, through Selenium) against the nodes on the mock board,
each node its own process; and its access rules, over plain HTTP."""
from __future__ import annotations

import json
import math
import os
import re
import socket
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path
from typing import List, Tuple

import pytest

from node_processes import STARTUP_S, NodeProcess, PlotterGraph, new_domain, params_file, read_trace, wait_until
from ros_graph import HELD_REPORTS, board_reports, held_still

pytestmark = pytest.mark.ros

REPO = Path(__file__).resolve().parent.parent
STEPS_PER_MM = 80.0
CHROME_ARGS = ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
               "--disable-background-networking", "--disable-component-update", "--disable-sync",
               "--disable-dev-shm-usage", "--window-size=1400,1000")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def web_ui(domain: int, *args: str) -> NodeProcess:
    return NodeProcess("plotter_web.web_ui_node", domain, ("-r", "__ns:=/plotter", "--params-file", params_file(),
                                                           *args))


def browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    options = webdriver.ChromeOptions()
    options.binary_location = "/usr/bin/chromium"
    for a in CHROME_ARGS:
        options.add_argument(a)
    return webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    domain = new_domain()
    work = tmp_path_factory.mktemp("web")
    graph = PlotterGraph(domain, work)
    port = free_port()
    ui = web_ui(domain, "-p", f"port:={port}", "-p", f"journal_dir:={graph.journal}")
    driver = None
    try:
        wait_until(lambda: f"plotter page on http://127.0.0.1:{port}/" in ui.output(), STARTUP_S, "the web server")
        driver = browser()
        driver.get(f"http://127.0.0.1:{port}/")
        graph.driver, graph.ui, graph.url, graph.work = driver, ui, f"http://127.0.0.1:{port}/", work
        wait_until(lambda: text(driver, "state") == "IDLE", 60, "IDLE on the page")
        yield graph
    except BaseException:
        print(graph.outputs(), "\n--- web_ui\n", ui.output())
        raise
    finally:
        try:
            if driver is not None:
                driver.quit()
            code = ui.interrupt()
            said = ui.output()
            ui.close()
        finally:
            # Whatever the page did: a graph left running would take the CPU (and its ROS domain)
            # from every test after it.
            graph.close()
        assert code == 0, said


def text(driver, element_id: str) -> str:
    return driver.find_element("id", element_id).text


def upload(page, name: str, content: str) -> None:
    path = page.work / name
    path.write_text(content)
    page.driver.find_element("id", "file").send_keys(str(path))


def ink_points(driver):
    d = driver.find_element("id", "ink").get_attribute("d") or ""
    nums = [float(v) for v in re.findall(r"-?\d+(?:\.\d+)?", d)]
    return [(nums[k], -nums[k + 1]) for k in range(0, len(nums) - 1, 2)]


def job_count(driver) -> str:
    return driver.find_element("id", "job-count").get_attribute("textContent")


def click_for_job(page, element_id: str) -> None:
    """Click a button that starts a job, and wait until the page shows the new job."""
    count = job_count(page.driver)
    page.driver.find_element("id", element_id).click()
    try:
        wait_until(lambda: job_count(page.driver) != count, 30, "the job to be sent")
    except TimeoutError:
        raise TimeoutError(f"no job sent; the page says: {text(page.driver, 'message')!r}") from None


def wait_job(page, status: str, timeout: float = 120) -> None:
    wait_until(lambda: text(page.driver, "job-status") == status, timeout, f"the job to be {status}")


def pen_steps(driver) -> Tuple[int, int]:
    """Where the page says the pen is, in steps: where the board's trace goes on
    from (a set origin moves the trace's origin with the board's)."""
    return round(float(text(driver, "x")) * STEPS_PER_MM), round(float(text(driver, "y")) * STEPS_PER_MM)


def drawing_check():
    """scripts/drawing_check.py: what a graph on the mock board drew, held against
    its programs, as the demo holds it."""
    scripts = str(REPO / "scripts")
    if scripts not in sys.path:
        sys.path.insert(0, scripts)
    import drawing_check
    return drawing_check


def graph_config():
    """The compiler settings of the graph's streamer (config/plotter.yaml)."""
    return drawing_check().graph_configs()[0]


def drawing_problems(page, program: str, before: int, start: Tuple[int, int]) -> List[str]:
    """Why the board's steps from trace row `before` on are not `program` drawn
    whole from `start` (steps), to the step the firmware core takes; none when they are."""
    drawn = [(x, y) for _, x, y in read_trace(page.trace)[before:]]
    return drawing_check().figure_problems(program, drawn, start, graph_config())


def svg_as_the_page_sends_it(svg: str, name: str, width: float) -> str:
    """The program the page makes of an uploaded SVG drawing `width` mm wide, with
    web_ui's work area and feed from config/plotter.yaml."""
    from plotter_bridge.gcode.limits import WorkArea
    from plotter_web import web_ui_node
    from plotter_web.jobs import svg_to_program
    values = drawing_check().node_values(web_ui_node.SPECS, params_file())
    area = WorkArea(*(float(values[k]) for k in ("x_min", "x_max", "y_min", "y_max")))
    return svg_to_program(svg.encode(), name, area, width, float(values["default_feed"]))


def test_an_uploaded_program_is_checked_run_and_drawn_live(page):
    program = "(web square)\nG21 G90\nG0 X30 Y30\nM3\nG1 X70 Y30 F3000\nG1 X70 Y70\nG2 X30 Y70 I-20 J0\n" \
              "G1 X30 Y30\nM5\nM2\n"
    before = len(read_trace(page.trace))
    upload(page, "square.gcode", program)
    wait_until(lambda: "fits the work area" in text(page.driver, "check-result"), 30, "the check")
    assert len(page.driver.find_elements("css selector", "#preview polyline")) == 1
    click_for_job(page, "run")
    wait_job(page, "succeeded")
    assert text(page.driver, "job-name") == "web square"
    trace = [(x, y) for _, x, y in read_trace(page.trace)[before:]]
    steps = set(trace)
    # The ink comes once a second: the last side, from (30, 70) down to (30, 30), on the page.
    wait_until(lambda: any(abs(x - 30) < 0.02 and 35 < y < 65 for x, y in ink_points(page.driver)),
               15, "the ink of the last side")
    ink = ink_points(page.driver)
    # Every ink point is a place the board stepped to; the ink spans what was drawn.
    drawn = [p for p in ink if 29.9 <= p[0] <= 70.1 and 29.9 <= p[1] <= 70.1]
    assert len(drawn) > 20
    assert all((round(x * STEPS_PER_MM), round(y * STEPS_PER_MM)) in steps for x, y in drawn)
    # The ink is the pen's path in the order it was drawn: each point a place the board stepped to
    # after the one before, the last on the last side.
    visits: dict = {}
    for k, xy in enumerate(trace):
        visits.setdefault(xy, []).append(k)
    at = 0
    for x, y in drawn:
        later = [k for k in visits[(round(x * STEPS_PER_MM), round(y * STEPS_PER_MM))] if k >= at]
        assert later, f"ink point ({x}, {y}) out of the order it was drawn in"
        at = later[0]
    assert abs(drawn[-1][0] - 30) < 0.02 and 30 - 0.02 <= drawn[-1][1] < 65, drawn[-1]
    # Positions come some 25 times a second, fewer on a loaded machine (seen: 4.1 mm, then 27 mm between
    # two samples beside CPU hogs): the ink reaches the square's sides within its longest travel
    # between two samples.
    xs, ys = [p[0] for p in drawn], [p[1] for p in drawn]
    travel = max(math.dist(a, b) for a, b in zip(drawn, drawn[1:]))
    assert (min(xs), max(xs), min(ys), max(ys)) == pytest.approx((30, 70, 30, 70), abs=max(2.5, travel + 0.1))
    assert text(page.driver, "x") == "30.000" and text(page.driver, "y") == "30.000"


def test_a_bad_file_shows_its_error_at_its_line_and_nothing_moves(page):
    before = len(read_trace(page.trace))
    upload(page, "bad.gcode", "G21 G90\nG0 X10 Y10\nG1 X500 Y10 F1000\nM2\n")
    wait_until(lambda: page.driver.find_elements("css selector", "#errors li"), 30, "the error")
    error = page.driver.find_element("css selector", "#errors li").text
    assert error.startswith("line 3: move to X500") and "G1 X500 Y10 F1000" in error, error
    assert not page.driver.find_element("id", "run").is_enabled()
    upload(page, "garbage.svg", "<svg this is not")
    wait_until(lambda: "cannot read" in text(page.driver, "errors"), 30, "the SVG's error")
    assert "cannot be drawn" in text(page.driver, "message")
    time.sleep(0.5)
    assert len(read_trace(page.trace)) == before


def test_an_svg_file_is_drawn(page):
    svg = ('<svg xmlns="http://www.w3.org/2000/svg" width="50mm" height="50mm" viewBox="0 0 50 50">'
           '<rect x="5" y="5" width="40" height="40" fill="none" stroke="black"/></svg>')
    page.driver.find_element("id", "svg-width").clear()
    page.driver.find_element("id", "svg-width").send_keys("40")
    upload(page, "box.svg", svg)
    wait_until(lambda: "fits the work area" in text(page.driver, "check-result"), 30, "the SVG's check")
    start, before = pen_steps(page.driver), len(read_trace(page.trace))
    click_for_job(page, "run")
    wait_job(page, "succeeded")
    program = svg_as_the_page_sends_it(svg, "box.svg", 40.0)
    assert drawing_problems(page, program, before, start) == []
    # The box is all the drawing there is: 40 mm wide as asked, in the middle of the area.
    drawn = {(x, y) for _, x, y in read_trace(page.trace)[before:]}
    corners = {(round(x * STEPS_PER_MM), round(y * STEPS_PER_MM)) for x in (80, 120) for y in (80, 120)}
    assert corners <= drawn, corners - drawn


def test_hold_resume_and_a_job_while_busy_is_refused(page):
    start, before = pen_steps(page.driver), len(read_trace(page.trace))
    program = "(slow)\nG21 G90\nG0 X20 Y120\nM3\n" + "G1 X180 Y120 F1500\nG1 X20 Y121\n" * 2 + "M5\nM2\n"
    upload(page, "slow.gcode", program)
    wait_until(lambda: "fits" in text(page.driver, "check-result"), 30, "the check")
    click_for_job(page, "run")
    wait_until(lambda: text(page.driver, "state") == "RUNNING", 30, "RUNNING")
    page.driver.find_element("id", "draw").click()                 # a shape while the file runs
    wait_until(lambda: "busy" in text(page.driver, "message"), 10, "the refusal")
    assert "'slow' is running" in text(page.driver, "message")
    page.driver.find_element("id", "hold").click()
    wait_until(lambda: text(page.driver, "state") == "HOLD", 15, "HOLD")
    with board_reports(page.domain) as reports:      # a hold brakes along the ramp before the pen rests
        wait_until(lambda: held_still(reports[-HELD_REPORTS:], page.trace), 30, "the pen at rest in HOLD")
    held = len(read_trace(page.trace))
    time.sleep(0.6)
    assert len(read_trace(page.trace)) == held
    page.driver.find_element("id", "resume").click()
    wait_until(lambda: text(page.driver, "state") == "RUNNING", 15, "RUNNING again")
    wait_until(lambda: "left" in text(page.driver, "job-left") or text(page.driver, "job-left") != "–", 10,
               "the time left")
    wait_job(page, "succeeded", 180)
    assert len(read_trace(page.trace)) > held > before
    # Held and resumed, the board went on from where it stopped: no step lost or taken twice.
    assert drawing_problems(page, program, before, start) == []


def test_emergency_stop_and_reset(page):
    from selenium.webdriver.support.ui import Select
    Select(page.driver.find_element("id", "shape")).select_by_visible_text("circle")
    for field, value in (("shape-x", "100"), ("shape-y", "100"), ("shape-size", "60"), ("shape-feed", "900")):
        el = page.driver.find_element("id", field)
        el.clear()
        el.send_keys(value)
    before = len(read_trace(page.trace))
    click_for_job(page, "draw")
    wait_until(lambda: text(page.driver, "state") == "RUNNING", 30, "RUNNING")
    wait_until(lambda: len(read_trace(page.trace)) > before, 30, "the board stepping")     # stopped mid-move
    page.driver.find_element("id", "estop").click()
    wait_until(lambda: text(page.driver, "state") == "ALARM", 10, "ALARM")
    wait_job(page, "aborted", 30)
    stopped = read_trace(page.trace)
    time.sleep(1.0)
    assert read_trace(page.trace) == stopped
    page.driver.find_element("id", "draw").click()
    wait_until(lambda: "alarm" in text(page.driver, "message"), 10, "the alarm refusal")
    page.driver.find_element("id", "reset").click()
    wait_until(lambda: text(page.driver, "state") == "IDLE", 15, "IDLE after reset")


def run_and_cancel(page, steps: int) -> None:
    """Run the checked file, cancel it once the board has taken `steps` steps of it (on a
    busy machine a fixed time into the run may find it not yet moving, or done), and wait
    until the board rests."""
    wait_until(lambda: "fits" in text(page.driver, "check-result"), 30, "the check")
    offset = page.trace.stat().st_size

    def stepped() -> int:
        with open(page.trace, "rb") as f:           # the trace's rows written since the run
            f.seek(offset)
            return f.read().count(b"\n")
    click_for_job(page, "run")
    wait_until(lambda: text(page.driver, "state") == "RUNNING", 30, "RUNNING")
    wait_until(lambda: stepped() >= steps, 60, f"{steps} steps of the job")
    page.driver.find_element("id", "cancel").click()
    wait_job(page, "canceled", 30)
    wait_until(lambda: text(page.driver, "state") == "IDLE", 30, "IDLE after the cancel")


def test_cancel_stops_the_job_and_set_origin_zeroes_the_position(page):
    from plotter_bridge.sim.expected import drawn_whole, program_steps
    wait_until(lambda: text(page.driver, "state") == "IDLE", 30, "IDLE")
    program = "(long)\nG21 G90\nG0 X20 Y40\nM3\n" + "G1 X180 Y40 F1200\nG1 X20 Y41\n" * 3 + "M5\nM2\n"
    upload(page, "long.gcode", program)
    start, before = pen_steps(page.driver), len(read_trace(page.trace))
    run_and_cancel(page, steps=1000)
    stopped = read_trace(page.trace)
    time.sleep(1.0)
    assert read_trace(page.trace) == stopped, "the board moved after the cancel"
    # Stopped part way: every step the program's, and far fewer than all of them (some 80000;
    # the cancel came after 1000).
    expected = program_steps(program, graph_config(), start)
    why = drawn_whole([(x, y) for _, x, y in stopped[before:]], expected, start, STEPS_PER_MM)
    found = re.fullmatch(r"the board stepped (\d+) of (\d+) steps, .*", why)
    assert found and 0 < int(found[1]) < int(found[2]) // 2, why
    page.driver.find_element("id", "set-origin").click()
    wait_until(lambda: (text(page.driver, "x"), text(page.driver, "y")) == ("0.000", "0.000"), 15, "the new origin")
    # Home, on a machine the bridge is not told has its limit switches: refused, saying how to turn it on.
    page.driver.find_element("id", "home").click()
    wait_until(lambda: "homing is off: set homing:=true" in text(page.driver, "message"), 15, "the homing refusal")


def test_jog_moves_the_pen_while_idle_and_never_out_of_the_area(page):
    from selenium.webdriver.support.ui import Select
    wait_until(lambda: text(page.driver, "state") == "IDLE", 30, "IDLE")
    page.driver.find_element("id", "set-origin").click()          # the pen on the area's lower left corner
    wait_until(lambda: (text(page.driver, "x"), text(page.driver, "y")) == ("0.000", "0.000"), 15, "the origin")

    def jog(selector: str, step: str, x: float, y: float) -> None:
        Select(page.driver.find_element("id", "jog-step")).select_by_visible_text(step)
        button = page.driver.find_element("css selector", selector)
        wait_until(button.is_enabled, 10, "the jog buttons")
        count = job_count(page.driver)
        button.click()
        wait_until(lambda: job_count(page.driver) != count, 30, "the jog to be sent")
        wait_job(page, "succeeded", 30)
        wait_until(lambda: (float(text(page.driver, "x")), float(text(page.driver, "y"))) == (x, y), 15,
                   f"the pen at {x}, {y}")
    jog(".jog[data-dx='1']", "10", 10.0, 0.0)
    jog(".jog[data-dy='1']", "0.1", 10.0, 0.1)
    jog(".jog[data-dy='1']", "1", 10.0, 1.1)
    jog(".jog[data-dx='-1']", "1", 9.0, 1.1)
    before = len(read_trace(page.trace))
    Select(page.driver.find_element("id", "jog-step")).select_by_visible_text("10")
    page.driver.find_element("css selector", ".jog[data-dy='-1']").click()      # to y = -8.9: off the area
    wait_until(lambda: "outside the work area" in text(page.driver, "message"), 10, "the refusal")
    time.sleep(0.5)
    assert len(read_trace(page.trace)) == before


THREE_PENS = ('<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="40mm" viewBox="0 0 60 40">'
              '<rect x="5" y="5" width="30" height="30" stroke="black" fill="none"/>'
              '<path d="M 40 10 L 55 25 M 40 25 L 55 10" stroke="red" fill="none"/>'
              '<path d="M 40 35 L 55 35" stroke="blue" fill="none"/></svg>')


def test_a_three_pen_drawing_is_planned_before_run_and_waits_at_each_pen_change(page):
    wait_until(lambda: text(page.driver, "state") == "IDLE", 30, "IDLE")
    page.driver.find_element("id", "svg-width").clear()
    page.driver.find_element("id", "svg-width").send_keys("60")
    upload(page, "three-pens.svg", THREE_PENS)
    wait_until(lambda: "fits the work area" in text(page.driver, "check-result"), 30, "the check")
    summary = text(page.driver, "plan-summary")
    assert re.search(r"drawn \d+\.\d mm with 3 pens \(2 pen changes, not timed\), pen-up travel \d+\.\d mm, "
                     r"\d+ (s|min \d\d s) on the board", summary), summary
    pens = [li.text for li in page.driver.find_elements("css selector", "#pens li")]
    assert len(pens) == 3 and '"black"' in pens[0] and '"red"' in pens[1] and '"blue"' in pens[2], pens
    colours = {line.value_of_css_property("stroke")
               for line in page.driver.find_elements("css selector", "#preview polyline")}
    assert colours == {"rgb(0, 0, 0)", "rgb(255, 0, 0)", "rgb(0, 0, 255)"}, colours
    assert page.driver.find_elements("css selector", "#travel polyline"), "the pen-up travel is shown"
    start, before = pen_steps(page.driver), len(read_trace(page.trace))
    click_for_job(page, "run")
    waiting = None
    for pen in ('layer 2 "red" #ff0000', 'layer 3 "blue" #0000ff'):
        wait_until(lambda: text(page.driver, "state") == "PEN_CHANGE" and text(page.driver, "next-pen") == pen,
                   120, f"the pen change to {pen}")
        assert page.driver.find_element("id", "pen-change").is_displayed()
        assert text(page.driver, "pen-state") == "up"
        waiting = read_trace(page.trace)
        time.sleep(1.0)
        assert read_trace(page.trace) == waiting, "nothing moves while the pen is changed"
        page.driver.find_element("id", "resume").click()
    wait_job(page, "succeeded", 120)
    assert not page.driver.find_element("id", "pen-change").is_displayed()
    assert len(read_trace(page.trace)) > len(waiting)
    # All three pens' paths, and the travel to the park position and back at each change.
    assert drawing_problems(page, svg_as_the_page_sends_it(THREE_PENS, "three-pens.svg", 60.0), before, start) == []


def test_the_layers_asked_for_are_planned_in_that_order_and_a_bad_order_is_refused(page):
    layers = page.driver.find_element("id", "svg-layers")
    try:
        page.driver.find_element("id", "svg-width").clear()
        page.driver.find_element("id", "svg-width").send_keys("60")
        layers.send_keys("3,1")
        page.driver.find_element("id", "svg-optimize").click()
        upload(page, "two-of-three-pens.svg", THREE_PENS)
        wait_until(lambda: "fits the work area" in text(page.driver, "check-result"), 30, "the check")
        pens = [li.text for li in page.driver.find_elements("css selector", "#pens li")]
        assert len(pens) == 2 and '"blue"' in pens[0] and '"black"' in pens[1], pens
        colours = {line.value_of_css_property("stroke")
                   for line in page.driver.find_elements("css selector", "#preview polyline")}
        assert colours == {"rgb(0, 0, 0)", "rgb(0, 0, 255)"}, colours
        layers.clear()
        layers.send_keys("4,1,1")
        page.driver.find_element("id", "check").click()
        wait_until(lambda: page.driver.find_elements("css selector", "#errors li"), 30, "the refusal")
        error = text(page.driver, "errors")
        assert "4 is not a layer" in error and "1 is given twice" in error and "3 'blue'" in error, error
        assert not page.driver.find_element("id", "run").is_enabled()
    finally:
        layers.clear()
        if page.driver.find_element("id", "svg-optimize").is_selected():
            page.driver.find_element("id", "svg-optimize").click()


def test_a_job_stopped_half_way_is_resumed_from_the_page(page):
    wait_until(lambda: text(page.driver, "state") == "IDLE", 30, "IDLE")
    upload(page, "halfway.gcode", "(halfway)\nG21 G90\nG0 X20 Y60\nM3\n" + "G1 X180 Y60 F3000\nG1 X20 Y61\n" * 2
           + "G1 X30 Y70\nM5\nM2\n")
    run_and_cancel(page, steps=6000)
    row = "#jobs tr:first-child"
    wait_until(lambda: "halfway" in page.driver.find_element("css selector", row).text, 15, "the job in the list")
    assert "interrupted" in page.driver.find_element("css selector", row).text
    button = page.driver.find_element("css selector", f"{row} .resume-job")
    wait_until(button.is_enabled, 10, "the Resume button")
    count = job_count(page.driver)
    button.click()
    wait_until(lambda: job_count(page.driver) != count, 30, "the resumed job to be sent")
    wait_job(page, "succeeded", 180)
    assert text(page.driver, "job-name") == "halfway (resumed)"
    end = read_trace(page.trace)[-1]
    assert (end[1], end[2]) == (30 * STEPS_PER_MM, 70 * STEPS_PER_MM), "finished where the program ends"
    wait_until(lambda: "resumed as" in page.driver.find_element("css selector", "#jobs").text, 15,
               "the list saying the job was resumed")


def test_the_page_picks_one_of_several_plotters_in_the_domain(page, tmp_path):
    from selenium.webdriver.support.ui import Select
    wait_until(lambda: text(page.driver, "state") == "IDLE", 30, "IDLE")
    second = PlotterGraph(page.domain, tmp_path, namespace="/second")
    try:
        picker = page.driver.find_element("id", "plotter")
        wait_until(lambda: picker.is_displayed() and len(Select(picker).options) == 2, 30, "the picker")
        assert [o.text for o in Select(picker).options] == ["/plotter", "/second"]
        first_steps, first_x = len(read_trace(page.trace)), text(page.driver, "x")
        Select(picker).select_by_visible_text("/second")
        wait_until(lambda: "now driving the plotter in /second" in text(page.driver, "message"), 15, "the pick")
        wait_until(lambda: text(page.driver, "state") == "IDLE", 60, "the second plotter's state")
        Select(page.driver.find_element("id", "jog-step")).select_by_visible_text("10")
        button = page.driver.find_element("css selector", ".jog[data-dx='1']")
        wait_until(button.is_enabled, 10, "the jog buttons")
        button.click()
        wait_until(lambda: text(page.driver, "x") == "10.000", 60, "the second plotter's pen at X10")
        assert read_trace(second.trace)[-1][1:] == (10 * STEPS_PER_MM, 0), "the second board moved"
        assert len(read_trace(page.trace)) == first_steps, "the first did not"
        # the pen reaches X10 a moment before the jog's result: a pick before it is refused as busy
        wait_until(lambda: text(page.driver, "message") == "jog: done", 30, "the jog's end")
        Select(picker).select_by_visible_text("/plotter")
        wait_until(lambda: "now driving the plotter in /plotter" in text(page.driver, "message"), 15, "back")
        # back on the first: its own pen, where it was, not the second's
        wait_until(lambda: text(page.driver, "x") == first_x and text(page.driver, "state") == "IDLE", 15,
                   f"the first plotter's pen at X{first_x}")
    finally:
        codes = second.close()
    assert all(c == 0 for c in codes), codes


def test_a_disconnected_board_is_shown_and_nothing_is_sent(tmp_path):
    domain = new_domain()
    bridge = NodeProcess("plotter_bridge.nodes.serial_bridge", domain,
                         ("-r", "__ns:=/plotter", "--params-file", params_file(), "-p", "port:=/nonexistent/tty9"))
    port = free_port()
    ui = web_ui(domain, "-p", f"port:={port}")
    driver = browser()
    try:
        wait_until(lambda: "plotter page on" in ui.output(), STARTUP_S, "the web server")
        driver.get(f"http://127.0.0.1:{port}/")
        wait_until(lambda: "not connected" in text(driver, "last-error")
                   and "/nonexistent/tty9" in text(driver, "last-error"), 30, "the bridge's error on the page")
        driver.find_element("id", "draw").click()
        wait_until(lambda: "not connected" in text(driver, "message"), 10, "the refusal")
        assert driver.find_element("id", "message").get_attribute("class") == "error"
    finally:
        driver.quit()
        ui.interrupt()
        ui.close()
        bridge.interrupt()
        bridge.close()


def _request(url: str, method: str = "GET", headers=None, data=None):
    req = urllib.request.Request(url, method=method, headers=headers or {}, data=data)
    try:
        with urllib.request.urlopen(req, timeout=10) as r:
            return r.status, r.read(), r.headers
    except urllib.error.HTTPError as e:
        return e.code, e.read(), e.headers


def test_binding_beyond_loopback_needs_a_token_and_every_request_carries_it():
    domain = new_domain()
    open_ui = web_ui(domain, "-p", "host:=0.0.0.0", "-p", f"port:={free_port()}")
    wait_until(lambda: not open_ui.alive(), 30, "web_ui without a token to exit")
    out = open_ui.output()
    open_ui.close()
    assert open_ui.proc.returncode == 1 and "Traceback" not in out, out
    assert "host = '0.0.0.0'" in out and "token" in out, out

    token = "s3cret-plotter-token"
    port = free_port()
    ui = web_ui(domain, "-p", "host:=0.0.0.0", "-p", f"port:={port}", "-p", f"token:={token}")
    base = f"http://127.0.0.1:{port}"
    try:
        wait_until(lambda: "plotter page on" in ui.output(), STARTUP_S, "the web server")
        assert token not in ui.output()
        refused = [("GET", "/", {}), ("GET", "/static/app.js", {}), ("GET", "/ws", {}),
                   ("POST", "/api/jog", {"X-Plotter": "1"}), ("POST", "/api/button/estop", {"X-Plotter": "1"}),
                   ("GET", "/?token=wrong-token-123", {}), ("GET", "/static/app.js", {"Authorization": "Bearer x"}),
                   ("GET", "/", {"Cookie": "plotter_token=nope"})]
        for method, path, headers in refused:
            status, body, _ = _request(base + path, method, headers, b"{}" if method == "POST" else None)
            assert status == 401, (method, path, status)
            assert b"token" in body
        status, body, headers = _request(f"{base}/?token={token}")
        assert status == 200 and b"<title>Plotter</title>" in body
        cookie = headers.get("Set-Cookie", "")
        assert cookie.startswith("plotter_token=") and "HttpOnly" in cookie and "SameSite=Strict" in cookie
        status, _, _ = _request(f"{base}/static/app.js", headers={"Cookie": f"plotter_token={token}"})
        assert status == 200
        status, _, _ = _request(f"{base}/static/app.js", headers={"Authorization": f"Bearer {token}"})
        assert status == 200
        # The token is not enough for a POST from another site's page: it cannot send X-Plotter.
        status, body, _ = _request(f"{base}/api/button/hold", "POST", {"Authorization": f"Bearer {token}"}, b"{}")
        assert status == 403
        status, body, _ = _request(f"{base}/api/jog", "POST", {"Authorization": f"Bearer {token}", "X-Plotter": "1",
                                                               "Content-Type": "application/json"},
                                   json.dumps({"dx": 1e9, "dy": 0}).encode())
        assert status == 400 and b"jog" in body
    finally:
        ui.interrupt()
        ui.close()


def test_the_page_is_served_from_the_package_without_a_cdn():
    static = REPO / "ros_ws" / "src" / "plotter_web" / "plotter_web" / "static"
    for f in static.iterdir():
        body = f.read_text()
        assert not re.search(r"(src|href)=\"(https?:)?//", body), f.name
        assert "import " not in body or f.suffix != ".js"


def test_the_screenshot_script_draws_through_the_page(tmp_path):
    import subprocess
    import sys
    out = tmp_path / "page.png"
    # The script's own waits (at most 30 + 60 + 30 + 180 s) end before this one, and say what they saw.
    r = subprocess.run([sys.executable, str(REPO / "scripts" / "web_screenshot.py"), "--out", str(out),
                        "--figures", "1"], capture_output=True, text=True, timeout=420,
                       env=dict(os.environ, ROS_DOMAIN_ID=str(new_domain())))
    assert r.returncode == 0, r.stdout + r.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 20000
