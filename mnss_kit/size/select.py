"""Which rung of a trained ladder to ship: the smallest that meets every quality target and the budget.

Targets, as the command line writes them:

    within:DB        PSNR at most DB below the largest rung's (the ladder's best-funded model)
    taau:DB          PSNR at least DB above TAAU's on the same frames (0: never below the free baseline)
    psnr:FLOOR       PSNR at least FLOOR dB
    ssim:FLOOR       SSIM at least FLOOR
    if_ssim:FLOOR    IF-SSIM at least FLOOR

A budget is estimated frame milliseconds on one device profile (an estimate, not a measurement).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import UserError

FLOOR_METRICS = ("psnr", "ssim", "if_ssim")


@dataclass(frozen=True)
class Target:
    kind: str  # "within", "taau" or a metric of FLOOR_METRICS
    value: float

    def __str__(self) -> str:
        return f"{self.kind}:{self.value:g}"

    def problem(self, row: dict, largest: dict, baselines: dict) -> str | None:
        """Why ``row`` misses this target (None when it meets it); ``baselines`` has TAAU's quality."""
        if self.kind == "taau":
            if "taau" not in baselines:
                return "no TAAU result to compare with"
            margin = row["psnr"] - baselines["taau"]["psnr"]
            return None if margin >= self.value else f"PSNR {margin:+.2f} dB against TAAU (needs {self.value:+g})"
        if self.kind == "within":
            gap = largest["psnr"] - row["psnr"]
            return None if gap <= self.value else f"PSNR {gap:.2f} dB below {largest['config']} (allowed {self.value:g})"
        value = row[self.kind]
        return None if value >= self.value else f"{self.kind} {value:.4f} < {self.value:g}"


@dataclass(frozen=True)
class Budget:
    device: str
    ms: float

    def __str__(self) -> str:
        return f"{self.ms:g} ms on {self.device}"

    def problem(self, row: dict) -> str | None:
        ms = (row.get("device_ms") or {}).get(self.device)
        if ms is None:
            return f"no estimate for {self.device}"
        return None if ms <= self.ms else f"estimated {ms:.2f} ms on {self.device} > {self.ms:g} ms"


def parse_target(text: str) -> Target:
    kind, sep, value = text.partition(":")
    if not sep or kind not in ("within", "taau", *FLOOR_METRICS):
        raise UserError(f"target '{text}': expected within:DB, taau:DB or one of {', '.join(m + ':FLOOR' for m in FLOOR_METRICS)}")
    try:
        number = float(value)
    except ValueError:
        raise UserError(f"target '{text}': '{value}' is not a number") from None
    if number != number or number < 0:
        raise UserError(f"target '{text}': the value must be a number >= 0")
    return Target(kind, number)


def choose(rows: list[dict], targets: list[Target], budget: Budget | None = None,
           baselines: dict | None = None) -> tuple[dict | None, dict[str, list[str]]]:
    """``(chosen row or None, {config: reasons it was not chosen})`` for a ladder of evaluated rungs.

    Each row has ``config``, ``macs_per_pixel``, ``psnr``, ``ssim``, ``if_ssim`` and ``device_ms``.
    The largest rung (most MACs per pixel) is the reference of ``within`` targets.  The chosen
    row is the cheapest (fewest MACs, then fewest parameters) that misses nothing."""
    if not rows:
        raise UserError("the ladder has no evaluated rung to choose from")
    largest = max(rows, key=lambda r: (r["macs_per_pixel"], r.get("params", 0)))
    misses = {}
    for row in rows:
        problems = [p for p in (t.problem(row, largest, baselines or {}) for t in targets) if p]
        if budget is not None and (p := budget.problem(row)):
            problems.append(p)
        misses[row["config"]] = problems
    passing = [r for r in rows if not misses[r["config"]]]
    chosen = min(passing, key=lambda r: (r["macs_per_pixel"], r.get("params", 0))) if passing else None
    return chosen, misses
