"""How far apart two candidate models' predictions are on a plan: the criterion of :mod:`bayescal.design.discriminate`.

The criterion.  Both candidates are linear in their parameters
(:mod:`bayescal.critique.extensions`): a marker's deflection is
``X0 β0 + XA βA`` under A and ``X0 β0 + XB βB`` under B, ``X0`` the classical
model.  If A is true, the best fit of B to noise-free data of a plan leaves the
weighted residual sum of squares

    λ_A = min_γ ‖XA βA − [X0 XB] γ‖²_W = βAᵀ (M_AA − M_AR M_RR⁺ M_RA) βA,

``M = Σ r Zᵀ W Z`` the information of the joint design ``Z = [X0 XA XB]``
summed over the plan's configurations (``r`` repeats, ``W = 1/(2σ²)``, two
tracker readings per deflection), ``R`` the columns of ``[X0 XB]``.  With
Gaussian noise, ``λ_A / 2`` nats is the expected log-likelihood ratio of A over
B on the plan's data when A is true (the Kullback-Leibler divergence of their
predictive distributions at known coefficients), the quantity a held-out ΔELPD
estimates less the cost of the fitted parameters.  ``βA`` and ``βB`` are each
model's fit to the tied campaign.

The plan maximises the smaller of ``λ_A / 2`` and ``λ_B / 2``: whichever of the
two is true, the plan should show it.

The critique separates the two when the held-out ΔELPD exceeds twice its
standard error, ``sqrt(K var(d))`` over the K configurations' differences: a
plan whose separation sits in a few configurations (the few where a load
reverses a joint's torque, for a lost motion) has a SE of its own size however
large the total.  Each configuration's share ``λ_k`` of the separation (the
rival fitted to the whole plan) gives the difference's expected mean ``λ_k / 2``
and variance ``λ_k``, hence the ΔELPD expected in its SEs (:func:`expected_z`),
which :class:`Discrimination` reports beside the nats.  Maximised instead of
the separation, it resolved the twin's tied torque-dependent compliance more
often and its tied lost motion less often, and with the command's search (four
starts on eight candidates per angle) lost motion in 8 of 20 seeds against 13
of 20 (``docs/critique.md``; measured before commit 1adf04f, while the search
scored options at other candidates' configurations, and not measured since):
the better the search, the more it fits the noise of coefficients taken from a
campaign that could not tell the two apart.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Discrimination", "separation", "ranked_separation", "ranked_fits", "separation_bound", "shares", "expected_z", "plan_z"]

_RIDGE = 1e-9
"""Ridge on the rival model's unit-diagonal information: a direction whose eigenvalue is below it (k1
under hanging loads, a lost motion no load of the plan reverses) is not fitted."""


@dataclass(frozen=True)
class Discrimination:
    """How well a plan separates two candidates.

    Attributes
    ----------
    between : tuple of str
        The candidates A and B.
    nats : tuple of float
        ``λ_A / 2`` and ``λ_B / 2``: the expected log-likelihood ratio of the true
        model over its rival on the plan's data, when A, respectively B, is true.
    z : tuple of float
        The held-out ΔELPD of the true model over its rival, in its standard errors,
        expected from how the separation is shared among the configurations
        (:func:`expected_z`); the critique separates the two above ``DETECTION_Z``.
    """

    between: tuple[str, str]
    nats: tuple[float, float]
    z: tuple[float, float]

    @property
    def worst(self) -> float:
        """The smaller of the two, nats: what the plan guarantees whichever is true."""
        return float(min(self.nats))

    def to_json(self) -> dict:
        a, b = self.between
        return {
            f"if_{a}_true_nats": round(self.nats[0], 3),
            f"if_{b}_true_nats": round(self.nats[1], 3),
            "worst_nats": round(self.worst, 3),
            f"if_{a}_true_z": round(self.z[0], 3),
            f"if_{b}_true_z": round(self.z[1], 3),
            "worst_z": round(float(min(self.z)), 3),
        }


def _residual(information: np.ndarray, own: np.ndarray, fitted: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """(..., p) the coefficients ``v`` of deflections ``Z_own β`` less their best fit by the columns ``fitted``, in plans of information (..., p, p)."""
    m_ro = information[..., fitted[:, None], own[None, :]]
    m_rr = information[..., fitted[:, None], fitted[None, :]]
    # unit diagonal and a ridge far below any direction a plan resolves: no fit along unexcited ones
    size = np.sqrt(np.einsum("...ii->...i", m_rr))
    size = np.where(size > 0, size, 1.0)
    # in place on the gathered copy, the ridge on the diagonal alone: the same quotients and sums as dividing into
    # a new array and adding the ridge's identity, without two more arrays the size of the batch's
    normal = m_rr
    normal /= size[..., :, None] * size[..., None, :]
    diagonal = np.arange(fitted.size)
    normal[..., diagonal, diagonal] += _RIDGE
    gamma = np.linalg.solve(normal, (m_ro / size[..., :, None]) @ beta[:, None])[..., 0] / size
    v = np.zeros(information.shape[:-2] + (information.shape[-1],))
    v[..., own] = beta
    v[..., fitted] -= gamma
    return v


def _directions(information: np.ndarray, blocks: tuple[slice, slice, slice], beta_a: np.ndarray, beta_b: np.ndarray) -> np.ndarray:
    """(..., 2, p) the coefficients ``v`` of the true model's deflections less the rival's best fit, ``λ = vᵀ M v``, A then B true.

    ``information`` (..., p, p) is the joint design's; ``blocks`` the columns of the classical model, of A and of B.
    """
    information = np.asarray(information)
    base, a, b = (np.arange(information.shape[-1])[s] for s in blocks)
    truths = ((a, beta_a, np.concatenate([base, b])), (b, beta_b, np.concatenate([base, a])))
    return np.stack([_residual(information, own, rival, beta) for own, beta, rival in truths], axis=-2)


def separation(information: np.ndarray, blocks: tuple[slice, slice, slice], beta_a: np.ndarray, beta_b: np.ndarray) -> np.ndarray:
    """(..., 2) ``λ_A / 2`` and ``λ_B / 2`` (nats) of plans with joint information ``information`` (..., p, p).

    ``blocks`` are the columns of the classical model, of A and of B in the joint design.
    """
    v = _directions(information, blocks, beta_a, beta_b)
    return np.maximum(0.5 * np.einsum("...ti,...ij,...tj->...t", v, np.asarray(information), v), 0.0)


def ranked_separation(information: np.ndarray, blocks: tuple[slice, slice, slice], beta_a: np.ndarray, beta_b: np.ndarray) -> np.ndarray:
    """:func:`separation` of many plans, to rank them: ``vᵀ M v`` as the product ``v M`` and then each row's dot with ``v``.

    einsum's three operands in one loop took 3.8 μs a 24 × 24 plan against 0.2 μs, a sixth of the discriminating
    search.  The sums' order moves the last digits (at most 4.4 × 10⁻¹⁵ relative on random plans,
    ``tests/design/test_discriminate.py``), and the starts of ``benchmarks/bench_design.py``'s search reach plans
    whose separations tie to those digits: a search ranks its candidates by this and keeps :func:`separation`'s value
    of the plan it takes, the value that decides between starts.  Each plan's value is its own whatever the batch, but
    for a batch of one, which NumPy multiplies by ``β`` in another order (its last digits differ).
    """
    return ranked_fits(information, blocks, beta_a, beta_b)[0]


def ranked_fits(information: np.ndarray, blocks: tuple[slice, slice, slice], beta_a: np.ndarray, beta_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`ranked_separation` (..., 2) of plans of information (..., p, p), and the fits ``v`` (..., 2, p) it is
    computed from, A then B true: the true model's coefficients on its columns, the rival's fit negated on the rival's."""
    v = _directions(information, blocks, beta_a, beta_b)
    return np.maximum(0.5 * np.einsum("...ti,...ti->...t", v @ np.asarray(information), v), 0.0), v


def separation_bound(partial: np.ndarray, fits: np.ndarray, blocks: tuple[slice, slice, slice]) -> tuple[np.ndarray, np.ndarray]:
    """Upper bounds on the separation of each of K plans of information ``partial`` (K, p, p) with one configuration added.

    ``fits`` (K, 2, p) are, for each plan and A then B true, the true model's coefficients on its columns and any fit
    of the rival, negated, on the rival's (:func:`ranked_fits`).  Returns ``constant`` (K, 2) and ``weights``
    (K, 2, p, p): with a configuration of information ``A`` added to plan k, ``λ_A / 2`` (t = 0) and ``λ_B / 2``
    (t = 1), as :func:`separation` and :func:`ranked_separation` give them, are at most
    ``max(constant[k, t] + Σ_ij weights[k, t, i, j] A_ij, 0) / 2`` nats, to rounding.

    The rival's fit ``γ`` minimises its residual plus the ridge's penalty ``ε γᵀ D² γ`` (``D²`` the rival's diagonal
    of the plan's information, 1 where it is 0), so the residual it leaves is at most the residual plus penalty of
    any other fit ``v``: ``vᵀ P v + vᵀ A v`` and the penalty on the larger plan.  No solve; the bound is as close as
    the fit given is to the larger plan's, the plan's own fit moved by one configuration for instance.
    """
    partial, v = np.asarray(partial), np.asarray(fits)
    # the ridge on the rival's columns, those where v is the fit's
    ridge = np.full((2, partial.shape[-1]), _RIDGE)
    ridge[0, blocks[1]], ridge[1, blocks[2]] = 0.0, 0.0
    penalty = v * v * ridge
    diagonal = np.einsum("kii->ki", partial)
    constant = np.einsum("kti,kti->kt", v @ partial, v) + np.einsum("kti,ki->kt", penalty, np.where(diagonal > 0, diagonal, 1.0))
    weights = v[..., :, np.newaxis] * v[..., np.newaxis, :]
    np.einsum("ktii->kti", weights)[...] += penalty
    return constant, weights


def expected_z(mean: np.ndarray, variance: np.ndarray) -> np.ndarray:
    """(...,) the held-out ΔELPD over its SE expected from K configurations' differences of mean ``mean`` and noise ``variance`` (..., K).

    The SE of the held-out comparison is ``sqrt(K var(d))`` over the K differences
    (:func:`~bayescal.critique.compare.compare_elpd`): it grows with how unequally
    the configurations share the difference as well as with their noise, so a
    separation that sits in a few configurations has a SE of its own size,
    whatever its total.  Expected: ``Σ m_k / sqrt(K/(K-1) Σ (m_k - m̄)² + Σ v_k)``.
    """
    k = mean.shape[-1]
    spread = np.sum((mean - mean.mean(axis=-1, keepdims=True)) ** 2, axis=-1) * (k / max(k - 1, 1))
    total = mean.sum(axis=-1)
    scale = np.sqrt(spread + variance.sum(axis=-1))
    return np.divide(total, scale, out=np.zeros_like(total), where=scale > 0)


def shares(information: np.ndarray, blocks: tuple[slice, slice, slice], beta_a: np.ndarray, beta_b: np.ndarray) -> np.ndarray:
    """(..., 2, K) each configuration's share ``λ_k`` of the separation of plans of K configurations of information (..., K, p, p), A then B true.

    The rival is fitted to the whole plan; ``Σ_k λ_k / 2`` is :func:`separation`.
    """
    information = np.asarray(information)
    v = _directions(information.sum(axis=-3), blocks, beta_a, beta_b)
    return np.einsum("...ti,...kij,...tj->...tk", v, information, v)


def plan_z(information: np.ndarray, blocks: tuple[slice, slice, slice], beta_a: np.ndarray, beta_b: np.ndarray) -> np.ndarray:
    """(..., 2) :func:`expected_z` of plans whose K configurations have information ``information`` (..., K, p, p), A then B true.

    With the coefficients known and Gaussian noise, configuration k adds a
    log-likelihood ratio of the true model over its rival of mean ``λ_k / 2`` and
    variance ``λ_k``.
    """
    lam = np.maximum(shares(information, blocks, beta_a, beta_b), 0.0)
    return expected_z(lam / 2, lam)
