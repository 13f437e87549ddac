"""How old a reported position is when it arrives."""
from __future__ import annotations

import bisect
from collections import defaultdict
from typing import Dict, List, Sequence, Tuple

Step = Tuple[float, int, int]       # (time, x, y) after a step
Report = Tuple[float, int, int]     # (time it arrived, x, y it reports)


def report_ages(steps: Sequence[Step], reports: Sequence[Report],
                moving: float = 0.01) -> Tuple[List[float], int]:
    """Per report that arrived while the pen moved: its arrival time minus
    the time of the step that brought the pen to the reported position (the
    latest such step before the arrival).  Reports of a position the pen then
    kept for longer than `moving` seconds (pen delays, dwells, the end) are
    left out: their age is the standstill's.  Returns the ages and the number
    of reports no step matched."""
    if len(steps) < 2:
        return [], 0
    at: Dict[Tuple[int, int], List[int]] = defaultdict(list)
    for k, (_, x, y) in enumerate(steps):
        at[(x, y)].append(k)
    t_first, t_last = steps[0][0], steps[-1][0]
    ages, unmatched = [], 0
    for t, x, y in reports:
        if not t_first <= t <= t_last:
            continue
        ks = at.get((x, y), [])
        j = bisect.bisect_right([steps[k][0] for k in ks], t)
        if j == 0:
            unmatched += 1
            continue
        k = ks[j - 1]
        if k + 1 >= len(steps) or steps[k + 1][0] - steps[k][0] > moving:
            continue
        ages.append(t - steps[k][0])
    return ages, unmatched
