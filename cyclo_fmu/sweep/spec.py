"""Sweep specifications: which designs to evaluate (grid, Latin hypercube or a table) and over
which envelope.

A spec is a TOML file::

    [sweep]
    method = "lhs"            # "grid", "lhs" (Latin hypercube) or "table"
    n = 200                   # lhs: number of designs
    seed = 1                  # lhs: sampler seed
    modes = ["S1", "S2"]      # operating modes evaluated (default: S1 and S2, the bench's)
    base = "design.toml"      # optional base design file or preset name (default: the paper's test drive)
    table = "designs.csv"     # table: one design per row, columns named like the fields

    [envelope]                # optional: model_core.paper.BenchEnvelope fields
    n_speed = 8

    [fields]                  # design-file keys (units as in the design file: e_mm is mm)
    e_mm = [1.5, 2.5, 5]                        # grid: [min, max, count]; lhs: [min, max]
    "friction.mu_boundary" = [0.07, 0.12, 3]
    z1 = [11, 21, 6]                            # whole-number fields are rounded

Relative paths (base, table) are taken from the spec file's folder. A field name without a
section is looked up in every section of the design file and must be unique.
"""
from __future__ import annotations

import dataclasses
import itertools
from pathlib import Path

import numpy as np

from model_core import CycloidInputError, DriveDesign
from model_core.design import design_from_dict, design_from_toml, design_to_dict
from model_core.paper import BenchEnvelope

import tomllib

METHODS = ("grid", "lhs", "table")
#: Largest number of designs one spec may ask for [1]: each costs about 40 ms for two modes on
#: the 8 x 8 envelope, so 10^6 designs are about half a day on 2 cores; more is a mistake.
MAX_DESIGNS = 1_000_000


def _base_design(path, base):
    """The sweep's base design: a design file next to the spec, or a preset name."""
    from model_core.presets import load_design, preset_names
    f = path.parent / str(base)
    if not f.exists() and str(base) in preset_names():
        return load_design(str(base))
    return design_from_toml(f)


@dataclasses.dataclass
class SweepSpec:
    base: dict                  # the base design as a design-file dict
    fields: dict                # qualified name "section.key" -> values (grid) or (lo, hi)
    method: str = "grid"
    n: int = 0
    seed: int = 1
    modes: tuple = ("S1", "S2")
    envelope: BenchEnvelope = BenchEnvelope()
    table: list = None          # table: list of {qualified name: value}

    def designs(self) -> list:
        """The designs to evaluate, as a list of {qualified field name: value} (design-file
        units), in a fixed order (the design id is the index)."""
        return list(self.iter_designs())

    def iter_designs(self):
        """:meth:`designs` one at a time (a grid is not expanded in memory; a Latin hypercube
        keeps one float per design and field)."""
        if self.method == "table":
            yield from self.table
            return
        names = list(self.fields)
        if self.method == "grid":
            axes = [self.fields[k] for k in names]
            for combo in itertools.product(*axes):
                yield dict(zip(names, combo))
            return
        rng = np.random.default_rng(self.seed)
        n = self.n
        cols = {}
        for k in names:     # one stratified, shuffled column per field (McKay et al. 1979)
            lo, hi = self.fields[k]
            u = (rng.permutation(n) + rng.random(n)) / n
            cols[k] = lo + u * (hi - lo)
        for i in range(n):
            yield {k: float(cols[k][i]) for k in names}

    def build(self, values: dict) -> DriveDesign:
        """The DriveDesign of one row (raises CycloidInputError naming the field)."""
        data = {s: dict(v) for s, v in self.base.items()}
        for q, v in values.items():
            section, key = q.split(".", 1)
            if isinstance(data[section].get(key), int) and not isinstance(v, bool):
                v = int(round(float(v)))
            data[section][key] = v
        return design_from_dict(data)


def _qualify(name: str, base: dict) -> str:
    if "." in name:
        section, key = name.split(".", 1)
        if section not in base or key not in base[section]:
            raise CycloidInputError("fields", name, "no such design-file key")
        return name
    hits = [s for s in base if name in base[s]]
    if len(hits) != 1:
        raise CycloidInputError("fields", name, "no such design-file key" if not hits else
                                f"ambiguous: give one of {', '.join(h + '.' + name for h in hits)}")
    return f"{hits[0]}.{name}"


def _number(field, v):
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
        raise CycloidInputError(field, v, "must be a finite number")
    return v


def check_envelope(env: BenchEnvelope) -> None:
    """Refuse an envelope the model cannot evaluate, naming the field: grid sizes whole numbers
    1-1000; input speeds within the running range of ``cyclo_fmu.limits`` (min <= max); input
    torques positive (no power flows at zero torque: the efficiency is undefined), min <= max."""
    from ..limits import check_speed_rpm
    for k in ("n_speed", "n_torque"):
        v = getattr(env, k)
        if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= 1000:
            raise CycloidInputError(f"envelope.{k}", v, "must be a whole number from 1 to 1000")
    for k in ("speed_min_rpm", "speed_max_rpm"):
        v = getattr(env, k)
        check_speed_rpm(f"envelope.{k}", v)
        if v < 0:
            raise CycloidInputError(f"envelope.{k}", v, "must be positive (the envelope's "
                                    "speeds are magnitudes; the mode sets the direction)")
    if env.speed_max_rpm < env.speed_min_rpm:
        raise CycloidInputError("envelope.speed_max_rpm", env.speed_max_rpm,
                                f"must not be below speed_min_rpm = {env.speed_min_rpm:g}")
    for k in ("torque_min", "torque_max"):
        v = getattr(env, k)
        if not v > 0:
            raise CycloidInputError(f"envelope.{k}", v, "must be a positive torque in N*m (no "
                                    "power flows at zero torque: the efficiency is undefined)")
    if env.torque_max < env.torque_min:
        raise CycloidInputError("envelope.torque_max", env.torque_max,
                                f"must not be below torque_min = {env.torque_min:g}")


def load_spec(path) -> SweepSpec:
    """Read and check a sweep spec (TOML); every error names the field."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise CycloidInputError("spec", str(path), f"cannot be read ({exc.strerror})")
    except UnicodeDecodeError:
        raise CycloidInputError("spec", str(path), "is not UTF-8 TOML text")
    except tomllib.TOMLDecodeError as exc:
        raise CycloidInputError("spec", str(path), f"is not valid TOML ({exc})")
    unknown = set(data) - {"sweep", "envelope", "fields"}
    if unknown:
        raise CycloidInputError("spec", sorted(unknown)[0], "unknown section (known: sweep, "
                                "envelope, fields)")
    for section in ("sweep", "envelope", "fields"):
        if not isinstance(data.get(section, {}), dict):
            raise CycloidInputError(section, data[section], f"must be a table ([{section}])")
    sw = data.get("sweep", {})
    method = sw.get("method", "grid")
    if method not in METHODS:
        raise CycloidInputError("sweep.method", method, f"must be one of {', '.join(METHODS)}")
    for key in ("base", "table"):
        if key in sw and not (isinstance(sw[key], str) and sw[key].strip()):
            raise CycloidInputError(f"sweep.{key}", sw[key], "must be a file name (a string)")
    base_design = _base_design(path, sw["base"]) if "base" in sw else DriveDesign()
    base = design_to_dict(base_design)
    modes = sw.get("modes", ["S1", "S2"])
    from model_core.kinematics import parse_mode
    if not isinstance(modes, list) or not modes:
        raise CycloidInputError("sweep.modes", modes, "must be a non-empty list of modes")
    modes = tuple("".join(parse_mode(m)[:2]) for m in modes)
    env_kw = data.get("envelope", {})
    known = {f.name for f in dataclasses.fields(BenchEnvelope)}
    for k, v in env_kw.items():
        if k not in known:
            raise CycloidInputError(f"envelope.{k}", v, f"unknown (known: {', '.join(sorted(known))})")
        _number(f"envelope.{k}", v)
    envelope = BenchEnvelope(**env_kw)
    check_envelope(envelope)
    fields, table, n = {}, None, 0
    raw = data.get("fields", {})
    if method == "table":
        if "table" not in sw:
            raise CycloidInputError("sweep.table", None, "method 'table' needs a CSV file")
        import pandas as pd
        tpath = path.parent / sw["table"]
        try:
            df = pd.read_csv(tpath)
        except (OSError, ValueError) as exc:
            raise CycloidInputError("sweep.table", str(tpath), f"cannot be read ({exc})")
        cols = {c: _qualify(c, base) for c in df.columns}
        table = [{cols[c]: (v.item() if hasattr(v, "item") else v) for c, v in row.items()}
                 for row in df.to_dict("records")]
        n = len(table)
        if n == 0:
            raise CycloidInputError("sweep.table", str(tpath), "has no rows (one design a row)")
    else:
        if not raw:
            raise CycloidInputError("fields", "{}", "name at least one design field to vary")
        for name, rng_ in raw.items():
            q = _qualify(name, base)
            want = 3 if method == "grid" else 2
            if not isinstance(rng_, list) or len(rng_) != want:
                raise CycloidInputError(f"fields.{name}", rng_, "must be [min, max, count]"
                                        if method == "grid" else "must be [min, max]")
            lo, hi = (_number(f"fields.{name}", x) for x in rng_[:2])
            if hi < lo:
                raise CycloidInputError(f"fields.{name}", rng_, "max must not be below min")
            if method == "grid":
                cnt = rng_[2]
                if not isinstance(cnt, int) or isinstance(cnt, bool) or not 1 <= cnt <= MAX_DESIGNS:
                    raise CycloidInputError(f"fields.{name}", rng_, "count must be a whole "
                                            f"number from 1 to {MAX_DESIGNS}")
                fields[q] = [float(x) for x in np.linspace(lo, hi, cnt)]
            else:
                fields[q] = (float(lo), float(hi))
        if method == "grid":
            n = int(np.prod([len(v) for v in fields.values()], dtype=float))
        else:
            n = sw.get("n")
            if not isinstance(n, int) or isinstance(n, bool) or n < 1:
                raise CycloidInputError("sweep.n", n, "must be a whole number >= 1")
    if n > MAX_DESIGNS:
        raise CycloidInputError("sweep", n, f"designs exceed {MAX_DESIGNS} (see MAX_DESIGNS)")
    seed = sw.get("seed", 1)
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise CycloidInputError("sweep.seed", seed, "must be a whole number >= 0")
    return SweepSpec(base=base, fields=fields, method=method, n=n, seed=seed, modes=modes,
                     envelope=envelope, table=table)
