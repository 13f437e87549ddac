"""A big drawing's plan (motion/preview.py, `plotter check --svg/--png`, the page's upload): read
as a stream, its paths kept within a budget of points, its lengths and time the whole job's.

Thinning (gcode/thinning.py) is checked as the eye would: every point lies within three times
the stated tolerance of a kept path, each path keeps its ends, and the budget holds; then the preview of
a random walk of tens of thousands of segments against the exact one, and what the preview
holds against the program's length.
"""
from __future__ import annotations

import asyncio
import io
import math
import random
import sys
import tracemalloc
from pathlib import Path
from typing import List, Tuple

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
import big_drawing  # noqa: E402

from plotter_bridge.motion.compiler import StreamerConfig  # noqa: E402
from plotter_bridge.gcode.thinning import Thinning  # noqa: E402
from plotter_bridge.motion.preview import preview_program  # noqa: E402

Point = Tuple[float, float]


def walk_text(lines: int, seed: int = 1) -> str:
    out = io.StringIO()
    big_drawing.write(lines, out, seed)
    return out.getvalue()


def _segment_distance(p: Point, a: Point, b: Point) -> float:
    dx, dy = b[0] - a[0], b[1] - a[1]
    d2 = dx * dx + dy * dy
    t = 0.0 if d2 == 0 else max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / d2))
    return math.hypot(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy)


def _distance_to(p: Point, lines: List[List[Point]]) -> float:
    return min(_segment_distance(p, a, b) if b is not None else math.dist(p, a)
               for line in lines for a, b in (zip(line, line[1:]) if len(line) > 1 else [(line[0], None)]))


def _random_paths(rng: random.Random, count: int, steps: int) -> List[List[Point]]:
    paths = []
    for _ in range(count):
        x, y, heading = rng.uniform(0, 100), rng.uniform(0, 100), rng.uniform(0, 6.3)
        path = [(x, y)]
        for _ in range(rng.randint(1, steps)):
            heading += rng.uniform(-1.0, 1.0)
            length = rng.choice((0.05, 0.3, 1.5))
            x, y = x + length * math.cos(heading), y + length * math.sin(heading)
            path.append((x, y))
        paths.append(path)
    return paths


@pytest.mark.parametrize("seed", range(8))
def test_thinning_keeps_every_point_within_three_tolerances_and_the_budget(seed):
    rng = random.Random(seed)
    paths = _random_paths(rng, rng.choice((40, 200)), rng.choice((5, 40)))
    budget = rng.choice((300, 1000, 3000))
    thinning = Thinning(budget)
    group = thinning.group()
    for path in paths:
        for k in range(1, len(path)):               # as moves arrive: each but the first continues its path
            thinning.add(group, [path[k - 1], path[k]], join=k > 1)
    kept = sum(len(line) for line in group)
    assert kept == thinning.count <= budget
    if sum(map(len, paths)) <= budget:
        assert thinning.tolerance == 0.0 and group == paths
        return
    assert thinning.tolerance > 0
    ends = {p for line in group for p in (line[0], line[-1])}
    for path in paths:
        for p in path:
            assert _distance_to(p, group) <= 3 * thinning.tolerance + 1e-9, (p, thinning.tolerance)
    # a path kept keeps its two ends; one that went had nothing new to draw
    kept = [path for path in paths if path[0] in ends]
    assert 0 < len(kept) <= len(paths)
    for path in kept:
        assert path[-1] in ends or path is paths[-1]


def test_under_its_budget_a_drawing_is_kept_exactly():
    rng = random.Random(7)
    paths = _random_paths(rng, 30, 20)
    thinning = Thinning(10_000)
    group = thinning.group()
    for path in paths:
        thinning.add(group, path, join=False)
    assert group == paths and thinning.tolerance == 0.0


def test_a_stippling_keeps_about_one_dot_per_cell():
    """20000 dots of 0.01 mm on a 50 mm square, 500 points: a dot (2 points) in each of ~190 cells
    is what fits, so the tolerance is the side of such a cell, within one doubling; a dot goes
    only where another one is."""
    thinning = Thinning(500)
    group = thinning.group()
    rng = random.Random(3)
    for _ in range(20_000):
        x, y = rng.uniform(0, 50), rng.uniform(0, 50)
        thinning.add(group, [(x, y), (x + 0.01, y)], join=False)
    assert sum(len(line) for line in group) <= 500
    fits = 50 / math.sqrt(500 * 3 // 4 // 2)
    assert fits <= thinning.tolerance < 2 * fits * 1.5, thinning.tolerance
    assert len(group) > 100, "the page is still covered"
    x_lo, y_lo, t = *thinning._grid[:2], thinning.tolerance
    cells = [(math.floor((line[0][0] - x_lo) / t), math.floor((line[0][1] - y_lo) / t))
             for line in group[:thinning._judged[0]]]
    assert len(set(cells)) == len(cells), "two dots in one cell"


@pytest.fixture(scope="module")
def walk() -> str:
    return walk_text(30_000)


def test_a_big_preview_has_the_exact_lengths_and_time_and_fewer_points(walk):
    config = StreamerConfig(area=None)
    exact = preview_program(walk, config, budget=10 ** 9)
    thin = preview_program(walk, config, budget=5000)
    assert exact.tolerance_mm == 0.0 and thin.tolerance_mm > 0
    assert thin.drawn_mm == pytest.approx(exact.drawn_mm, rel=1e-9)
    assert thin.travel_mm == pytest.approx(exact.travel_mm, rel=1e-9)
    assert thin.seconds == pytest.approx(exact.seconds, rel=1e-9)
    assert thin.commands == exact.commands
    points = sum(len(line) for layer in thin.layers for line in layer.lines) + sum(len(t) for t in thin.travel)
    assert points <= 5000 < sum(len(line) for layer in exact.layers for line in layer.lines)
    assert f"drawn here to within {thin.tolerance_mm:.2g} mm" in thin.summary()
    # what is kept is the drawing: the ends of every stroke of the exact one are near a kept stroke
    drawn = [line for layer in thin.layers for line in layer.lines]
    rng = random.Random(1)
    for line in rng.sample([line for layer in exact.layers for line in layer.lines], 40):
        for p in (line[0], line[len(line) // 2], line[-1]):
            assert _distance_to(p, drawn) <= 3 * thin.tolerance_mm + 1e-6


def test_what_a_preview_holds_does_not_grow_with_the_program():
    """Four times the lines, the same budget: the peak of what the preview allocates grows by far
    less than the program (a few bytes a line: the lengths and time are sums)."""
    config = StreamerConfig(area=None)

    def peak(text: str) -> int:
        tracemalloc.start()
        try:
            preview_program(text, config, budget=3000)
            return tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
    small, big = walk_text(4000), walk_text(16_000)
    grown = peak(big) - peak(small)
    assert grown < 10 * (16_000 - 4000), f"{grown} bytes more for 12000 more lines"


def test_the_page_takes_an_upload_of_twenty_megabytes():
    """The page's upload passes the HTTP server with a 20 MB program (the check is the preview's:
    test_a_big_preview_...), and a bigger one than the streamer takes is refused with its size."""
    from aiohttp import FormData
    from aiohttp.test_utils import TestClient, TestServer
    from plotter_web.app import WebApp
    from plotter_web.jobs import MAX_UPLOAD, Checked

    class Backend:
        def __init__(self) -> None:
            self.received: List[int] = []

        def snapshot(self) -> list:
            return []

        def check(self, filename, data, width, layers, optimize):
            self.received.append(len(data))
            return Checked(filename, "G0 X1\n")

    line = b"G1 X123.456 Y78.901\n"
    twenty = line * (20 * 1024 * 1024 // len(line) + 1)

    async def post(data: bytes):
        backend = Backend()
        async with TestClient(TestServer(WebApp(backend).app)) as client:
            form = FormData()
            form.add_field("file", data, filename="big.gcode", content_type="text/plain")
            response = await client.post("/api/check", data=form, headers={"X-Plotter": "1"})
            return response.status, await response.json(), backend.received
    status, body, received = asyncio.run(post(twenty))
    assert status == 200 and received == [len(twenty)], body
    status, body, received = asyncio.run(post(b"G0 X1\n" * (MAX_UPLOAD // 6 + 200_000)))
    assert status == 413 and received == [] and f"limit {MAX_UPLOAD}" in body["error"], body
