"""The words the dashboard uses, each explained in a sentence or two for a student.

Data only: the shell shows it on the start page, in the Glossary dialog every page can open, and as
tooltips on the start page's words. A term is the symbol as the pages print it, then its name.
"""

from __future__ import annotations

GLOSSARY: dict[str, str] = {
    "Q_T, the flooded threshold flow":
        "The oil flow a bearing leaks out of its two sides when its supply groove is just full, at ambient "
        "pressure. Feed less than Q_T and the film cannot stay complete (starved); feed more and the surplus "
        "pressurizes the groove (flooded). About 546 ml/min for the paper's bearings at 75 Hz.",
    "Q1, Q2, the supply flows":
        "The oil flows fed to bearing 1 and bearing 2, in ml/min: what lubeviz identifies from the vibration.",
    "starved / flooded":
        "Starved: the supply is below Q_T, so the film ahead of the load is incomplete, the pressure zone "
        "shrinks and the journal sinks lower (ε rises). Flooded: at or above Q_T the groove is full and the "
        "extra oil is pushed out under pressure. The verdicts say starved below 95 % of Q_T, over-supplied "
        "above 105 %, normal between.",
    "θ, the oil fraction":
        "The share of the gap filled with liquid oil at a point of the film: 1 where the film is full and "
        "carries pressure, below 1 in the cavitated zone after the minimum film, where oil runs in streamers "
        "with air at ambient pressure.",
    "ε, the eccentricity ratio":
        "How far the journal's centre sits from the bearing's centre, as a fraction of the radial clearance "
        "c: 0 is centred, 1 would touch the bush. A heavier load, thinner oil or a starved film raises it.",
    "S, the Sommerfeld number":
        "A bearing's duty in one dimensionless number, S = μ N L D / W · (R/c)² (viscosity μ, speed N in "
        "rev/s, length L, diameter D, load W, radius R, clearance c). A large S means a light, fast, centred "
        "journal (small ε); a small S a heavily loaded one (ε near 1).",
    "fb, the forward/backward ratio":
        "The shaft's orbit at the running speed split into a forward-whirling circle (Zf, turning with the "
        "shaft) and a backward one (Zb): fb = |Zf| / |Zb|. A round orbit has a large fb, a flat one fb near 1; "
        "it does not depend on how large the unbalance is.",
    "φ, the orbit angle":
        "The tilt of the orbit's long axis, (arg Zf + arg Zb) / 2, in degrees (the same orbit tilted by 180° "
        "is the same orbit). With fb it is the feature that tells the two supply flows apart.",
    "χ² and p":
        "χ² adds up the squared differences between the model's features and the record's, each divided by "
        "its expected uncertainty (noise and model budget). p is the chance of a χ² at least that large if "
        "the model were right: a tiny p says the model does not explain the record (see Diagnose).",
    "model error / model budget":
        "What the model itself does not know exactly (film mesh, shaft damping, the oil's viscosity and each "
        "clearance within their tolerances), carried through to the features as an extra uncertainty. It is "
        "added to the record's noise so that the intervals and the χ² test stay honest.",
    "95 % interval":
        "The range of flows that fits the record within its noise and the model budget: 95 of 100 such "
        "intervals from repeated records would contain the true flow. A flooded bearing's interval may have "
        "no upper end, since more oil changes the vibration little once the groove is full.",
    "iterations":
        "The steps a search takes from its starting guess to the answer, one model evaluation and correction "
        "each. The paper's Newton search needed about 3 per case; 'not converged' means it ran out of steps.",
}
