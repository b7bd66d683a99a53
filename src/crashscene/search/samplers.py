"""Samplers of the unit cube, asked for a round of points and told the round's objectives.

No optimiser is written here; each sampler wraps a published method from a kept package:
- `random`: uniform points from a seeded numpy Generator (the baseline).
- `halton`: scrambled Halton sequence (scipy.stats.qmc; Owen scrambling), space-filling, not adaptive.
- `ce`: VerifAI's cross-entropy sampler (`ContinuousCrossEntropySampler`, the one Scenic's
  `verifaiSamplerType = 'ce'` uses: 5 buckets per parameter, smoothing alpha 0.9). VerifAI updates its
  bucket distribution towards every sample whose objective is below a threshold; as in the cross-entropy
  method (Rubinstein 1999), the threshold of each round is the elite quantile (ELITE_FRACTION) of the
  objectives seen so far, so it also moves before the first failure.
- `bo`: Bayesian optimisation with Optuna's tree-structured Parzen estimator (Bergstra et al. 2011,
  multivariate TPE), rounds asked in a batch with the constant-liar strategy; the first round is its
  random start-up. (VerifAI's own `bo` sampler needs GPyOpt, which does not install with numpy 2 era
  packages; TPE is the kept alternative.)
- `cmaes`: the covariance matrix adaptation evolution strategy (Hansen and Ostermeier 2001; Hansen 2016, "The
  CMA Evolution Strategy: A Tutorial") from `cma` (pycma, by its author), one generation per round (population =
  the round size), started at the centre of the cube with the step size its documentation prescribes (the
  optimum within x0 +- 3 sigma0: sigma0 = 1/6 of the unit width), bounds kept by pycma's own `BoundTransform`.

All randomness comes from the seed: the same seed asks the same points given the same objectives.
"""
from __future__ import annotations

import numpy as np

from crashscene.search.errors import SearchError

SAMPLERS = ("random", "halton", "ce", "bo", "cmaes")
ELITE_FRACTION = 0.2   # share of evaluated points that count as elite in the cross-entropy update
CE_BUCKETS = 5         # VerifAI's default for continuous parameters
CE_ALPHA = 0.9         # VerifAI's default smoothing
CMA_SIGMA0 = 1.0 / 6.0   # [unit cube] pycma: the optimum is expected within x0 +- 3 sigma0 (x0 = the centre)


class Sampler:
    """Proposes rounds of points in [0, 1]^D (`ask`) and learns from their objectives (`tell`)."""

    name = "abstract"

    def __init__(self, dimension: int, seed: int):
        self.dimension = dimension
        self.seed = seed

    def ask(self, n: int) -> np.ndarray:
        raise NotImplementedError

    def tell(self, points: np.ndarray, values: np.ndarray) -> None:
        """Objectives of the last `ask` (finite: invalid variations already replaced by the worst value)."""


class RandomSampler(Sampler):
    name = "random"

    def __init__(self, dimension: int, seed: int):
        super().__init__(dimension, seed)
        self.rng = np.random.default_rng(np.random.SeedSequence([seed, 1]))

    def ask(self, n: int) -> np.ndarray:
        return self.rng.random((n, self.dimension))


class HaltonSampler(Sampler):
    name = "halton"

    def __init__(self, dimension: int, seed: int):
        super().__init__(dimension, seed)
        from scipy.stats import qmc

        self.engine = qmc.Halton(d=dimension, scramble=True, seed=np.random.default_rng([seed, 2]))

    def ask(self, n: int) -> np.ndarray:
        return self.engine.random(n)


class CrossEntropySampler(Sampler):
    name = "ce"

    def __init__(self, dimension: int, seed: int):
        super().__init__(dimension, seed)
        from verifai.features import Box
        from verifai.samplers.cross_entropy import ContinuousCrossEntropySampler

        self.sampler = ContinuousCrossEntropySampler(domain=Box(*[(0.0, 1.0)] * dimension), alpha=CE_ALPHA,
                                                     thres=0.0, buckets=CE_BUCKETS)
        self.round = 0
        self.buckets: list[np.ndarray] = []
        self.seen: list[float] = []

    def ask(self, n: int) -> np.ndarray:
        # VerifAI draws from numpy's global generator: seed it per round, restore the caller's state after
        state = np.random.get_state()
        np.random.seed(np.random.SeedSequence([self.seed, 3, self.round]).generate_state(1)[0])
        try:
            drawn = [self.sampler.getVector() for _ in range(n)]
        finally:
            np.random.set_state(state)
        self.round += 1
        self.buckets = [info for _, info in drawn]
        return np.array([vector for vector, _ in drawn], dtype=float)

    def tell(self, points: np.ndarray, values: np.ndarray) -> None:
        self.seen.extend(float(v) for v in values)
        elite = float(np.quantile(self.seen, ELITE_FRACTION))
        self.sampler.thres = float(np.nextafter(elite, np.inf))   # VerifAI updates on rho < thres
        for vector, info, value in zip(points, self.buckets, values):
            self.sampler.updateVector(tuple(vector), info, float(value))


class TpeSampler(Sampler):
    name = "bo"

    def __init__(self, dimension: int, seed: int, startup: int = 10):
        super().__init__(dimension, seed)
        import optuna

        optuna.logging.set_verbosity(optuna.logging.WARNING)
        sampler = optuna.samplers.TPESampler(seed=int(seed) & 0xFFFFFFFF, multivariate=True, constant_liar=True,
                                             n_startup_trials=startup)
        self.study = optuna.create_study(sampler=sampler, direction="minimize")
        self.dists = {f"x{i}": optuna.distributions.FloatDistribution(0.0, 1.0) for i in range(dimension)}
        self.pending: list = []

    def ask(self, n: int) -> np.ndarray:
        self.pending = [self.study.ask(self.dists) for _ in range(n)]
        return np.array([[trial.params[f"x{i}"] for i in range(self.dimension)] for trial in self.pending])

    def tell(self, points: np.ndarray, values: np.ndarray) -> None:
        for trial, value in zip(self.pending, values):
            self.study.tell(trial, float(value))
        self.pending = []


class CmaEsSampler(Sampler):
    name = "cmaes"

    def __init__(self, dimension: int, seed: int, population: int):
        super().__init__(dimension, seed)
        import cma

        rng = np.random.default_rng(np.random.SeedSequence([seed, 4]))
        options = {"popsize": population, "bounds": [0.0, 1.0], "seed": float("nan"),  # no global seeding
                   "randn": lambda *shape: rng.standard_normal(shape), "verbose": -9, "verb_log": 0,
                   "verb_disp": 0}
        self.es = cma.CMAEvolutionStrategy(np.full(dimension, 0.5), CMA_SIGMA0, options)
        self.asked: list[np.ndarray] = []

    def ask(self, n: int) -> np.ndarray:
        self.asked = self.es.ask(n)
        return np.clip(np.array(self.asked, dtype=float), 0.0, 1.0)

    def tell(self, points: np.ndarray, values: np.ndarray) -> None:
        if len(self.asked) >= self.es.popsize:  # a last, partial round is never followed by another ask
            self.es.tell(self.asked, [float(v) for v in values])
        self.asked = []


def create_sampler(name: str, dimension: int, seed: int, round_size: int) -> Sampler:
    """The sampler called `name` (one of SAMPLERS)."""
    if name == "random":
        return RandomSampler(dimension, seed)
    if name == "halton":
        return HaltonSampler(dimension, seed)
    if name == "ce":
        return CrossEntropySampler(dimension, seed)
    if name == "bo":
        return TpeSampler(dimension, seed, startup=round_size)
    if name == "cmaes":
        return CmaEsSampler(dimension, seed, population=round_size)
    raise SearchError(f"--sampler {name!r} is not allowed; allowed: {', '.join(SAMPLERS)}")
