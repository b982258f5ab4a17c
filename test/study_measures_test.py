#!/usr/bin/python3
"""Unit tests of scripts/study_measures.py (issue 38): the study's primary measure, its intervals, the null and the
oracle, on synthetic curves whose answers are known. No ROS, no knowledge base: test/study.sh checks the same
measures against a real study's knowledge bases."""
import math
import os
import random
import sys
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts"))
import study_measures as sm  # noqa: E402


def study(rng, designs, seeds, objects, budget=40, noise=0.15, every=5):
    """Synthetic cells: each design's error of object o after k experiments is scale * base_o * (1 + k)^-0.3 times a
    seed's log-normal noise (one draw per cell: seeds differ in level, as real ones do)."""
    cells = {}
    for design, scale in designs.items():
        for s in seeds:
            level = math.exp(rng.gauss(0, noise))
            cells[(design, s)] = {o: {k: scale * (0.01 + 0.01 * i) * (1 + k) ** -0.3 * level
                                      for k in range(0, budget + 1, every)}
                                  for i, o in enumerate(objects)}
    return cells


class Measures(unittest.TestCase):
    def test_an_object_that_does_not_move_is_not_counted(self):
        rows = [{"object": "block", "distance": 0.05, "dx": 0.0004, "dy": 0.0, "dyaw": 0.001} for _ in range(5)]
        rows += [{"object": "cube", "distance": 0.05, "dx": 0.03, "dy": 0.01, "dyaw": 0.2} for _ in range(5)]
        rows += [{"object": "bar", "distance": 0.04, "dx": 0.0, "dy": 0.0, "dyaw": 0.5} for _ in range(5)]  # turns only
        moving, shares = sm.moving_objects(rows, ["block", "cube", "bar", "absent"])
        self.assertEqual(moving, ["cube", "bar"])
        self.assertLess(shares["block"], sm.MOVES_SHARE)
        self.assertAlmostEqual(shares["bar"], 0.02 * 0.5 / 0.04)
        self.assertNotIn("absent", shares)

    def test_objects_weigh_equally_whatever_their_pushes(self):
        curves = {"a": {0: 0.1, 10: 0.05}, "b": {0: 0.3, 10: 0.15, 20: 0.1}}
        self.assertEqual(sm.balanced_curve(curves, ["a", "b", "c"]), [(0, 0.2), (10, 0.1)])
        self.assertEqual(sm.balanced_curve(curves, ["c"]), [])

    def test_the_area_is_the_mean_log_error_over_the_budget(self):
        self.assertAlmostEqual(sm.log_area([(0, 0.02), (20, 0.02), (40, 0.02)]), math.log(0.02))
        # log error falling linearly from log(0.04) to log(0.01): its mean is the log of the geometric middle, 0.02
        curve = [(k, 0.04 * 0.25 ** (k / 40)) for k in range(0, 41, 4)]
        self.assertAlmostEqual(sm.log_area(curve), math.log(0.02), places=9)
        self.assertAlmostEqual(sm.error_at(curve, 10), curve[3][1])  # the first checkpoint at or after 10: k = 12
        self.assertAlmostEqual(sm.error_at(curve, 99), curve[-1][1])

    def test_a_design_with_half_the_error_has_a_ratio_of_one_half(self):
        rng = random.Random(1)
        cells = study(rng, {"random": 1.0, "better": 0.5}, range(1, 11), ["a", "b"])
        out = sm.measures(cells, ["a", "b"], 40)
        row = next(r for r in out["rows"] if r["design"] == "better")
        r, lo, hi = row["area"]
        self.assertTrue(lo < r < hi)
        self.assertLess(hi, 1.0)
        self.assertAlmostEqual(row["paired"][0], 0.5 * math.exp(
            sum(math.log(cells[("better", s)]["a"][0] / cells[("random", s)]["a"][0] / 0.5) for s in range(1, 11)) / 10),
            places=9)
        self.assertIn("lower error than random", out["verdicts"][0])

    def test_the_null_comes_out_one_within_its_interval_at_the_nominal_rate(self):
        # 200 studies of 20 seeds, random against random: the 95 % interval must hold 1.00 in about 95 % of them
        # (a bootstrap percentile interval at n = 20 is slightly narrow; below 88 % it would mislead).
        rng = random.Random(7)
        held = 0
        for i in range(200):
            cells = study(rng, {"random": 1.0, "random_null": 1.0}, range(1, 21), ["a"], budget=10, every=10)
            logs = {d: [sm.log_area(sm.balanced_curve(cells[(d, s)], ["a"])) for s in range(1, 21)]
                    for d in ("random", "random_null")}
            _, lo, hi = sm.ratio(logs["random_null"], logs["random"], random.Random(i), rounds=400)
            held += lo <= 1.0 <= hi
        self.assertGreaterEqual(held, 176)
        self.assertLessEqual(held, 200)

    def test_the_report_says_plainly_when_no_difference_can_be_claimed(self):
        rng = random.Random(3)
        cells = study(rng, {"random": 1.0, "random_null": 1.0, "oracle": 0.6}, range(1, 9), ["a", "b"], noise=0.3)
        for s in range(1, 9):  # a design whose cells are random's own, shifted by one seed: no difference at all
            cells[("same", s)] = cells[("random", s % 8 + 1)]
        out = sm.measures(cells, ["a", "b"], 40)
        self.assertEqual(out["designs"][:2], ["random", "random_null"])
        self.assertTrue(out["null_ok"])
        same = next(v for v in out["verdicts"] if v.startswith("same:"))
        self.assertIn("no difference from random can be claimed", same)
        self.assertGreater(out["detectable"], 0.0)
        self.assertLess(out["detectable"], 1.0)

    def test_the_oracle_fraction_is_zero_for_random_and_one_for_the_oracle(self):
        rng = random.Random(5)
        base = [rng.gauss(-4, 0.1) for _ in range(10)]
        oracle = [b - 0.5 for b in base]
        f, lo, hi = sm.oracle_fraction(oracle, base, oracle, rng)
        self.assertAlmostEqual(f, 1.0)
        f, _, _ = sm.oracle_fraction(base, base, oracle, rng)
        self.assertAlmostEqual(f, 0.0)
        self.assertIsNone(sm.oracle_fraction(base, base, base, rng))  # an oracle that gains nothing shares nothing

    def test_no_fraction_of_a_gain_the_oracle_does_not_show(self):
        # Every object learnable: the oracle is random design, and a fraction of its "gain" would be noise over noise.
        rng = random.Random(11)
        cells = study(rng, {"random": 1.0, "oracle": 1.0, "better": 0.8}, range(1, 9), ["a", "b"], noise=0.3)
        out = sm.measures(cells, ["a", "b"], 40)
        self.assertIs(out["oracle_gains"], False)
        self.assertTrue(all("oracle_fraction" not in row for row in out["rows"]))
        # ... and with an oracle that gains, the fraction is there.
        cells = study(random.Random(11), {"random": 1.0, "oracle": 0.6, "better": 0.8}, range(1, 9), ["a", "b"], noise=0.3)
        out = sm.measures(cells, ["a", "b"], 40)
        self.assertIs(out["oracle_gains"], True)
        self.assertIn("oracle_fraction", next(r for r in out["rows"] if r["design"] == "better"))

    def test_more_seeds_detect_smaller_effects(self):
        rng = random.Random(9)
        few = [rng.gauss(0, 0.2) for _ in range(5)]
        many = [rng.gauss(0, 0.2) for _ in range(80)]
        self.assertGreater(sm.detectable_effect(few), sm.detectable_effect(many))



class Competence(unittest.TestCase):
    def test_ratios_and_references_average_the_moving_objects_equally(self):
        goal_cells = {}
        for s in range(1, 6):
            goal_cells[("random", s)] = {"cube": {0: 0.04, 20: 0.02, 40: 0.02}, "bar": {0: 0.02, 20: 0.02, 40: 0.01},
                                         "block": {0: 9.0, 20: 9.0, 40: 9.0}}
            goal_cells[("good", s)] = {o: {k: e / 2 for k, e in c.items()} for o, c in goal_cells[("random", s)].items()}
        references = {"cube": (0.05, 0.01), "bar": (0.03, 0.005), "block": (1.0, 1.0)}
        comp = sm.competence(goal_cells, references, ["cube", "bar"], budget=40)
        self.assertAlmostEqual(comp["means"]["random"]["all"], 0.015)
        self.assertAlmostEqual(comp["means"]["random"]["quarter"], 0.02)  # the first checkpoint at or after k=10
        self.assertAlmostEqual(comp["random_choice"], 0.04)
        self.assertAlmostEqual(comp["best_choice"], 0.0075)
        row = comp["rows"][0]
        self.assertEqual(row["design"], "good")
        for name in ("quarter", "half", "all"):
            self.assertAlmostEqual(row[name][0], 0.5)

if __name__ == "__main__":
    unittest.main()
