"""The product's choice of scene model (select/scene.py, issue 47) scored on scene_model.py's signals table.

A run prices the scene models (K = 1..MAX_OBJECTS objects, no background or a background image; over each
background fewest objects first, up to the first dearer than one before: ``up_to_dearer``) by their best judged
segmentation's relative residual r to the whole views, ``model_price``:

    price = log r + K log(1 / OBJECT_GAIN)

and, for each background, races the cheapest and the runner-up too where its price is within a factor
RACE_MARGIN of it (``cheapest_each``), over an image only where the image earns its place (``image_earned``: its
start alone leaves at most OBJECT_GAIN of the views, ``r_image0``, or the cheapest model over it is priced at
most OBJECT_GAIN of the cheapest plain one); the held-out views then choose. Here the same functions and constants,
imported from nct.select.scene, read each model's r off the table as the run computes it (`judged`). Scored
against the truth's model (signals.csv's ``background`` and ``n_objects``, read only here): per group, the
truth's K the cheapest over its background (the judge's part) and the truth among the raced (what the held-out
views can then choose); every file outside the generalisation benchmark; the misses; the sensitivity to the two
settings; the signals' seconds.

    python benchmarks/diagnostics/scene_model_rule.py benchmarks/results/scene_model/signals.csv \\
        --out benchmarks/results/scene_model/rule.md
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from nct.init.judge import explains_nothing
from nct.run.tables import markdown_table
from nct.select.candidates import BACKGROUND_ORDER, SceneModel
from nct.select.scene import (
    MAX_OBJECTS,
    MIN_INTERIOR,
    OBJECT_GAIN,
    RACE_MARGIN,
    model_price,
    raced,
    up_to_dearer,
)

GAINS, MARGINS = (0.6, 0.7, 0.8, 0.9), (1.0, 1.25, 1.5, 2.0)  # the sensitivity grid
MODELS = tuple(SceneModel(k, b) for b in BACKGROUND_ORDER for k in range(1, MAX_OBJECTS + 1))  # a run's order


@dataclass(frozen=True)
class Rule:
    """The rule's settings: the price of an object (``gain``) and the runner-up's ``margin``; by default the
    product's."""

    gain: float = OBJECT_GAIN
    margin: float = RACE_MARGIN

    def __str__(self) -> str:
        return f"gain {self.gain:g}, margin {self.margin:g}"


@dataclass(frozen=True)
class Scene:
    """One row of signals.csv: its name, category, the truth's model (scoring only) and the row's text."""

    name: str
    category: str
    truth: SceneModel
    row: dict[str, str]

    def value(self, key: str) -> float:
        text = self.row.get(key, "")
        return float(text) if text not in ("", None) else math.nan


def read_scenes(path: Path) -> list[Scene]:
    """signals.csv as `Scene`s."""
    with open(path, newline="") as fh:
        return [Scene(r["name"], r["category"], SceneModel(int(r["n_objects"]), r["background"]), r)
                for r in csv.DictReader(fh)]


def judged(scene: Scene, model: SceneModel) -> float:
    """``model``'s best judged residual as a run prices it (select/scene.set_up, relative to the whole views; NaN:
    not offered, select/scene.offered). No background: K = 1 on a steady mover's compensated frames where the views
    hold its path (``r_lone1``), else the plain frames. Over an image, the table's ``r_image`` (the judge's residual
    there times the norm of the views less the image's projection over the whole views'); where nothing moves a
    run's objects there start empty: not offered. Objects the judge gives no intensity (``a`` all at its floor:
    judge.explains_nothing) explain nothing: not offered. K > 1 with a rim among the objects (``inside`` under
    MIN_INTERIOR): not offered."""
    k, image = model.n_objects, model.background == "image"
    levels = scene.row.get(f"a_{model.background}{k}") or ""
    if image and scene.value("moving_share") == 0 or levels and explains_nothing(np.array(levels.split(), float)):
        return math.nan
    inside = scene.value(f"inside_{model.background}{k}")
    if k > 1 and inside < MIN_INTERIOR:
        return math.nan
    if image:
        return scene.value(f"r_image{k}")
    lone = scene.value("r_lone1") if k == 1 else math.nan
    return lone if math.isfinite(lone) else scene.value(f"r_none{k}")


def prices(scene: Scene, rule: Rule) -> dict[SceneModel, float]:
    """The models a run prices (``up_to_dearer`` over each background; NaN: not offered), priced (``model_price``)."""
    def priced(model: SceneModel) -> float | None:
        r = judged(scene, model)
        return model_price(r, model, rule.gain) if math.isfinite(r) else None

    return {m: p for b in BACKGROUND_ORDER for m, p in up_to_dearer([m for m in MODELS if m.background == b],
                                                                    priced).items()}


def race(scene: Scene, rule: Rule = Rule()) -> list[SceneModel]:
    """The models a run races (`nct.select.scene.raced`: the cheapest of each background's priced ones, over an
    image only where it earns its place, ``r_image0`` what its start alone leaves), simplest first."""
    return raced(prices(scene, rule), scene.value("r_image0"), rule.gain, rule.margin)


def k_right(scene: Scene, rule: Rule) -> bool:
    """Whether the cheapest model over the truth's background has the truth's K (the judge's part)."""
    over = {m: p for m, p in prices(scene, rule).items() if m.background == scene.truth.background}
    return bool(over) and min(over, key=over.get) == scene.truth


def categories(scenes: Sequence[Scene]) -> list[tuple[str, list[Scene]]]:
    """All the scenes, then by category."""
    return [("all", list(scenes))] + [(c, [s for s in scenes if s.category == c])
                                      for c in dict.fromkeys(s.category for s in scenes)]


def groups(scenes: Sequence[Scene]) -> list[tuple[str, list[Scene]]]:
    """`categories`, the generalisation scenes also by layout, motion, noise and K, textured by family."""
    out = categories(scenes)
    gen = [s for s in scenes if s.category == "generalisation"]
    for label, pick in (("layout", lambda s: s.row["detail"].split(",")[0]),
                        ("moving", lambda s: "static" if set(s.row["detail"].split(",")[1].split()) == {"static"}
                         else "moving"),
                        ("noise", lambda s: s.row["detail"].split(",")[-1].strip()),
                        ("K", lambda s: str(s.truth.n_objects))):
        out += [(f"generalisation, {label} {v}", [s for s in gen if pick(s) == v])
                for v in dict.fromkeys(map(pick, gen))]
    tex = [s for s in scenes if s.category == "textured"]
    families = dict.fromkeys(s.row["detail"].split(",")[0] for s in tex)
    return out + [(f"textured, {f}", [s for s in tex if s.row["detail"].startswith(f)]) for f in families]


def share(n: int, of: int) -> str:
    return f"{n} ({n / of:.0%})" if of else "–"


def accuracy_table(scenes: Sequence[Scene], rule: Rule) -> str:
    """Per group: files, the truth's K the cheapest over its background, the truth among those raced, and the
    models raced per file (what the race costs)."""
    rows = []
    for label, mine in groups(scenes):
        picks = [race(s, rule) for s in mine]
        rows.append([label, len(mine), share(sum(k_right(s, rule) for s in mine), len(mine)),
                     share(sum(s.truth in p for s, p in zip(mine, picks)), len(mine)),
                     f"{np.mean([len(p) for p in picks]):.2f}" if picks else "–"])
    return markdown_table(["files", "n", "K right over the truth's background", "truth raced", "models raced"], rows)


def named(models: list[SceneModel]) -> str:
    return ", ".join(f"{m.background} K={m.n_objects}" for m in models) or "–"


def files_table(scenes: Sequence[Scene], rule: Rule) -> str:
    """Every file outside the generalisation benchmark: the truth's model, those raced, whether the truth is."""
    rows = [[s.name, s.category, s.row["detail"], named([s.truth]), named(race(s, rule)),
             "yes" if s.truth in race(s, rule) else "no"]
            for s in scenes if s.category != "generalisation"]
    return markdown_table(["file", "category", "detail", "truth", "raced", "truth raced"], rows)


def residuals(scene: Scene, background: str) -> str:
    """The residuals a run prices at K = 1..MAX_OBJECTS over one background."""
    return " ".join(f"{judged(scene, SceneModel(k, background)):.3f}" for k in range(1, MAX_OBJECTS + 1))


def misses_table(scenes: Sequence[Scene], rule: Rule) -> str:
    """Every file whose truth is not raced, with the residuals the run prices."""
    rows = [[s.name, s.row["detail"], named([s.truth]), named(race(s, rule)), s.value("level_gap"),
             residuals(s, "none"), residuals(s, "image"), s.value("moving_share")]
            for s in scenes if s.truth not in race(s, rule)]
    return markdown_table(["file", "detail", "truth", "raced", "level gap", "r none K=1..4", "r image K=1..4",
                           "moving share"], rows)


def confusion_table(scenes: Sequence[Scene], rule: Rule) -> str:
    """The misses' pairs (the truth's model, those raced) by count."""
    pairs = Counter((named([s.truth]), named(race(s, rule))) for s in scenes if s.truth not in race(s, rule))
    return markdown_table(["truth", "raced", "files"], [[t, p, n] for (t, p), n in pairs.most_common()])


def sensitivity_table(scenes: Sequence[Scene], rule: Rule) -> str:
    """K right over the truth's background / the truth raced (files) per gain (rows) and margin (columns);
    ``rule``'s cell in bold."""
    rows = []
    for gain in GAINS:
        cells = []
        for margin in MARGINS:
            other = replace(rule, gain=gain, margin=margin)
            cell = f"{sum(k_right(s, other) for s in scenes)} / {sum(s.truth in race(s, other) for s in scenes)}"
            cells.append(f"**{cell}**" if other == rule else cell)
        rows.append([f"{gain:g}", *cells])
    return markdown_table(["gain", *(f"margin {m:g}" for m in MARGINS)], rows)


def single_signals_table(scenes: Sequence[Scene]) -> str:
    """K read off one signal alone against the truth's K: the mixture's BIC and AIC components less one (the
    background), and the distinct levels Algorithm 1 finds."""
    reads = {"BIC components - 1": lambda s: s.value("bic_components") - 1,
             "AIC components - 1": lambda s: s.value("aic_components") - 1,
             "Algorithm 1's distinct levels": lambda s: s.value("mixture_levels")}
    rows = [[name, *(share(sum(read(s) == s.truth.n_objects for s in mine), len(mine))
                     for _, mine in categories(scenes))] for name, read in reads.items()]
    return markdown_table(["K from", *(label for label, _ in categories(scenes))], rows)


def cost_table(scenes: Sequence[Scene]) -> str:
    """Seconds per signal (one thread), median and largest over the files."""
    names = list(dict.fromkeys(k[2:] for s in scenes for k in s.row if k.startswith("t_")))
    rows = []
    for name in names:
        seconds = [v for s in scenes if math.isfinite(v := s.value(f"t_{name}"))]
        rows.append([name, float(np.median(seconds)), float(np.max(seconds))])
    return markdown_table(["signal", "median s", "largest s"], rows)


def report(scenes: Sequence[Scene], rule: Rule, command: str) -> str:
    """The note: the rule, its accuracy per group, the files, the misses, the sensitivity, the costs."""
    sensitivity = [part for label, mine in categories(scenes)
                   for part in (f"### {label} ({len(mine)} files)", "", sensitivity_table(mine, rule), "")]
    return "\n".join([
        f"# The scene model a run races, on the signals table ({rule})", "", f"Command: `{command}`", "",
        "price = log r + K log(1/gain), r the judged residual a run prices (scene_model_rule.py's `judged`); for each "
        "background the cheapest is raced, the runner-up too where within a factor `margin`, over an image only where "
        "the image cuts the views (its start alone, r_image0) or the cheapest plain model's price to `gain` "
        "(nct.select.scene's model_price, cheapest_each and image_earned); the held-out views choose among them.", "",
        "## Accuracy", "", accuracy_table(scenes, rule), "",
        "## Files outside the generalisation benchmark", "", files_table(scenes, rule), "",
        "## Misses (the truth not raced)", "", misses_table(scenes, rule), "", confusion_table(scenes, rule), "",
        "## Sensitivity (files: K right over the truth's background / truth raced)", "", *sensitivity,
        "## K from one signal alone", "", single_signals_table(scenes), "",
        "## Seconds per signal (one thread)", "", cost_table(scenes), ""])


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("signals", type=Path, help="scene_model.py's signals.csv")
    parser.add_argument("--out", type=Path, help="write the note here (default: print it)")
    parser.add_argument("--gain", type=float, default=OBJECT_GAIN, help=f"an object's price (default {OBJECT_GAIN})")
    parser.add_argument("--margin", type=float, default=RACE_MARGIN, help=f"the race's (default {RACE_MARGIN})")
    args = parser.parse_args(argv)
    if not args.signals.is_file():
        parser.exit(2, f"scene_model_rule: error: {args.signals}: no such file\n")
    command = "python " + " ".join([Path(sys.argv[0]).as_posix(), *(argv if argv is not None else sys.argv[1:])])
    text = report(read_scenes(args.signals), Rule(args.gain, args.margin), command)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
