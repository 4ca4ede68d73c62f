"""lubeviz: how well each hydrodynamic bearing of a machine is lubricated, from the shaft's vibration.

Numerics only (film -> rotor -> signals -> identify); the Panel app lives in `lubeviz.app`.

BLAS threads: lubeviz's matrices are small (84 DOFs, 168 states), where a multi-threaded BLAS only
adds overhead, and on a busy 2-core machine oversubscription made one record synthesis 7x slower
(1.6 s -> 11 s, measured). Parallel work runs across processes instead. So, unless the user has
chosen otherwise, one BLAS thread per process; this only takes effect if numpy is not yet imported.
"""

import os as _os

for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "OMP_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")

__version__ = "0.2.0"
