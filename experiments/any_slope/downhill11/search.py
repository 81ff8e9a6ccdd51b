"""Can a constant rhythm (no learning) walk down 11°? The fixed-parameter search of
`quadcos.evaluation.fixed_search` on a 2-m run-in, 4 m down at 11° and 2 m of flat, in an env that
pays r_s only for steps moving at ≥ 0.3 m/s (so standing still does not win), 14-s episodes.

    python experiments/any_slope/downhill11/search.py > experiments/any_slope/downhill11/search.log
"""

import json
from pathlib import Path

from quadcos.evaluation import fixed_search

HERE = Path(__file__).resolve().parent
COURSE = "sections:-11@4,0@2"  # the crest at x = 2 m (the run-in), the foot at x = 6 m

result = fixed_search.search_fixed(
    COURSE,
    num_candidates=256,
    robots_per_candidate=2,
    rounds=3,
    seconds=14.0,
    include_trot=True,
    env_overrides={"survival_min_speed": 0.3},
    on_round=lambda entry: print(json.dumps(entry), flush=True),
)
(HERE / "search.json").write_text(json.dumps(result, indent=1) + "\n")
for candidate in result["ranking"]:
    print(candidate["policy"], "falls", candidate["fall_rate"], "speed", round(candidate["mean_forward_speed"], 3))
