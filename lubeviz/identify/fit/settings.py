"""Identification settings (SPEC §5): the paper's choices, and ours, declared once with their docs."""

from __future__ import annotations

import math

import param

from ...model.quantity import Quantity


class IdentificationSettings(param.Parameterized):
    """How Q1, Q2 are searched for. Defaults: our best mode; `paper()` gives the paper's method."""

    mode = param.Selector(default="best", objects=["best", "paper"],
                          doc="'paper': Eq. 11 errors, generalized Newton-Raphson, 3x3 multi-start (Sec. 2.3); "
                              "'best': noise-weighted least squares on all invariant features, trust region")
    lower = Quantity(0.25, bounds=(0.01, 1.0), unit="", doc="Lower bound of the search, fraction of Q_T")
    upper = Quantity(2.0, bounds=(1.0, 5.0), unit="", doc="Upper bound of the search, fraction of Q_T")
    starts = param.List([0.7, 1.0, 1.3], item_type=float,
                        doc="Start grid per bearing, fractions of Q_T (3x3 starts ordered by total error)")
    max_iterations = param.Integer(15, bounds=(1, 200), label="Paper mode: Newton iterations per start",
                                   doc="Paper mode: generalized Newton-Raphson iterations per start (best mode's "
                                       "Levenberg-Marquardt stops on its own tolerances)")
    fd_step = Quantity(0.02, bounds=(1e-5, 0.2), unit="",
                       doc="Paper mode: central-difference step of the Jacobian, fraction of Q_T")
    phi_scale = Quantity(math.radians(30.0), bounds=(0.0, None), unit="rad", display_unit="deg",
                         display_scale=180.0 / math.pi,
                         doc="Paper mode: angular scale of the phi error, eps_phi = (phi_s - phi_m)/scale. "
                             "0 means the paper's literal (phi_s - phi_m)/phi_m, which blows up where phi_m "
                             "passes near 0 (strongly starved bearing 1)")
    accept_total_error = Quantity(0.05, bounds=(0.0, None), unit="",
                                  doc="Paper mode: a start has converged when its steps stall with "
                                      "eps_T = sum |eps| below this")
    step_tolerance = Quantity(1e-4, bounds=(0.0, None), unit="",
                              doc="A search stops when its step is below this fraction of Q_T")
    features = param.List(["fb1", "fb2", "phi1", "phi2", "log_zf_ratio", "arg_zf_ratio"], item_type=str,
                          doc="Best mode: features used (all invariants of an unbalance of unknown size/phase)")
    include_model_error = param.Boolean(True, doc="Best mode: weigh the fit, its chi2 test and the flows' "
                                        "intervals by the model's own uncertainty (identify.forward.budget) as well as the "
                                        "record's noise; off: the noise alone (flags most real records)")
    min_line_snr = Quantity(3.0, bounds=(0.0, None), unit="",
                            doc="Refuse a record whose forward or backward 1X line is below this many "
                                "noise standard deviations")
    oil_check = param.Selector(default="warn", objects=["warn", "always", "never"],
                               doc="Best mode, one record without the static position: hotter or colder oil than "
                                   "declared mimics a supply change. 'always': also give the flows' intervals with "
                                   "the oil viscosity free within x0.75-1.33 (this says how much; builds the tables "
                                   "of that range once if needed; time: BENCHMARKS \"Dimensionless tables\"); 'warn': a warning says the flows assume "
                                   "the declared oil; 'never': neither. Never decided by what the cache holds")
    response = param.Selector(default="linear", objects=["linear", "large orbit"],
                              doc="The rotor's response model: 'linear' (each film's K, C at the static equilibrium, "
                                  "for orbits small against the clearance); 'large orbit' (the film force along the "
                                  "orbit by harmonic balance, `orbit_harmonics`, `orbit_time_rounds`; probe effects "
                                  "only). `--effect large_orbit` on the command line sets it")
    orbit_harmonics = param.Integer(16, bounds=(5, 32),
                                    doc="With large orbits declared: harmonics of the balance's periodic orbit (points "
                                        "per revolution: 24 at 5, else 4 per harmonic; fewer than 5 are refused, the "
                                        "budget's truncation term is measured from 5 up). More harmonics: a smaller "
                                        "truncation error at more time a record; the sigma carries the truncation at "
                                        "any count. A balance that stalls near the orbit at this count falls back "
                                        "to 8, then 5 harmonics, and the result says so. Error and time per count: "
                                        "BENCHMARKS \"Rates over time-integration records\"")
    orbit_time_rounds = param.Integer(0, bounds=(0, 5),
                                      doc="With large orbits declared: time rounds after the balance's (each integrates "
                                          "the model in time at the answer, one time integration, two near Q_T, and "
                                          "corrects the balance's truncation). Error and time: BENCHMARKS \"Time "
                                          "rounds on all 12 records\". 0: the balance alone")
    speed_tolerance = Quantity(0.02, bounds=(0.0, 1.0), unit="",
                               doc="Refuse a record whose speed differs from the model's by more than this fraction")

    @classmethod
    def paper(cls, **overrides) -> "IdentificationSettings":
        return cls(mode="paper", **overrides)
