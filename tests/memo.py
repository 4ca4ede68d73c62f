"""The film's time integration, kept on disk for the suite as the independent records are (a seed).

Several tests compare a method against the time integration of the same films (the harmonic balance, the whirl's
eigenvalue, the large-orbit record): the integration is their reference, 15-85 s each, and it is the same
integration on every run until its code or its inputs change. `time_response` runs
`rotor.film_transient.film_time_response` once and keeps its result in `<cache_dir()>/independent/memo-<key>.npz`,
where `tests/seeds/refresh.sh` collects seeds. The key is a sha256 of every input, taken apart down to its arrays
and numbers (the rotor's matrices, each bearing's equilibrium, film and coefficients, the unbalances, the start
state, the step, the duration) and of the code of the film and rotor packages (`lubeviz.code_key`), so that a change
to either makes the integration run again; a file with another key or a non-finite value is not read. Timings
(`seconds` fields) and the fields a dataclass leaves out of its equality (a film's factorization kept for reuse) are
not inputs. `integration_memoized(monkeypatch, module)` puts it in place of the integration a module calls (the
whirl's onset, the records it writes; the time rounds' gap)."""

from __future__ import annotations

import dataclasses
import enum
import hashlib
import json
import math

import numpy as np
import param

from lubeviz.identify.tables.cache import cache_dir
from lubeviz.rotor.film_transient import FilmTimeResponse, film_time_response
from lubeviz.verification import equilibria

MEMO_FORMAT = 3  # 2: floats to DIGITS digits (keys that hold on another host); 3: DIGITS 9 -> 6


# A number the suite computes (a film's equilibrium, the rotor's matrices) is the host's in its last bits: another
# CPU's BLAS and numpy kernels moved them by ~1e-14, and every memo's key with its bytes, so that a fresh clone there
# ran each of the seeded integrations again (session 60). So floats enter a key to DIGITS significant digits, and a
# float array by its sum of magnitudes to DIGITS digits and three weighted sums as fractions of it to DIGITS
# decimals: a change to one entry by more than a part in 10**DIGITS of the whole changes the key; noise well below
# that does not, but at a rounding edge. DIGITS was 9 until session 66: on another host (an AMD EPYC, the
# packages of its own fresh install) the films' equilibria came out ~1e-11 apart, not ~1e-14 (the kept
# integrations' outputs 0.8-2.4e-11 apart), and every one of the 7 seeded integrations ran again. At 6 digits such
# noise flips a rounding about once in 1e5 numbers; inputs 1e-6 apart give integrations 1e-6 apart, far inside
# every tolerance the tests that read them hold (percents).
DIGITS = 6


def _number(v) -> str:
    if isinstance(v, (bool, np.bool_, int, np.integer, str, type(None))):
        return repr(v)
    c = complex(v)
    part = [f"{x + 0.0:.{DIGITS}g}" for x in (c.real, c.imag)]
    return part[0] if isinstance(v, (float, np.floating)) else ",".join(part)


def _float_array(h, a: np.ndarray) -> None:
    parts = [a.real, a.imag] if np.iscomplexobj(a) else [a]
    for x in parts:
        x = np.asarray(x, dtype=float).ravel()
        scale = float(np.abs(x).sum())
        h.update(f"s{scale:.{DIGITS}g}".encode())
        if scale > 0.0:
            w = np.linspace(-1.0, 1.0, x.size)
            for m in (x.sum(), (x * w).sum(), (x * w * w).sum()):
                h.update(f",{round(float(m) / scale, DIGITS) + 0.0!r}".encode())


def _digest(h, value) -> None:
    """Feed `value`, taken apart down to arrays and plain numbers, into the hash `h` (floats to DIGITS digits)."""
    if isinstance(value, np.ndarray):
        a = np.ascontiguousarray(value)
        h.update(f"a{a.dtype.str}{a.shape}".encode())
        if a.dtype.kind in "fc":
            _float_array(h, a)
        else:
            h.update(a.tobytes())
    elif isinstance(value, enum.Enum):
        h.update(f"e{type(value).__qualname__}.{value.name}".encode())
    elif isinstance(value, (bool, int, float, complex, str, type(None), np.number, np.bool_)):
        h.update(f"v{type(value).__name__}:{_number(value)}".encode())
    elif dataclasses.is_dataclass(value):
        h.update(f"d{type(value).__qualname__}(".encode())
        for f in dataclasses.fields(value):
            if f.name != "seconds" and f.compare:  # a timing, or a derived cache (a factorization) not in its value
                h.update(f.name.encode())
                _digest(h, getattr(value, f.name))
        h.update(b")")
    elif isinstance(value, param.Parameterized):
        h.update(f"p{type(value).__qualname__}(".encode())
        for name in sorted(value.param):
            if name != "name":
                h.update(name.encode())
                _digest(h, getattr(value, name))
        h.update(b")")
    elif isinstance(value, (list, tuple)):
        h.update(f"l{len(value)}[".encode())
        for v in value:
            _digest(h, v)
        h.update(b"]")
    elif isinstance(value, dict):
        h.update(f"m{len(value)}{{".encode())
        for k in sorted(value, key=repr):
            _digest(h, k)
            _digest(h, value[k])
        h.update(b"}")
    elif callable(value):
        h.update(b"callable")  # a progress callback: not an input of the result
    else:
        raise TypeError(f"tests.memo: {type(value).__name__} in a memo key")


def _key(args, kwargs) -> str:
    h = hashlib.sha256()
    h.update(json.dumps({"format": MEMO_FORMAT, "kind": "film_time_response",
                         "code": equilibria.code_version("film", "rotor")}).encode())
    _digest(h, list(args))
    _digest(h, {k: v for k, v in kwargs.items() if k != "progress"})
    return h.hexdigest()


def _arrays(tr: FilmTimeResponse) -> dict:
    return {"t": tr.t, "nodes": np.asarray(tr.nodes, dtype=np.int64), "displacement": tr.displacement,
            "film_force": tr.film_force, "residual_force": tr.residual_force,
            "counts": np.array([tr.film_solves, tr.sor_fallbacks], dtype=np.int64), "seconds": np.array(tr.seconds)}


def _response(data: dict) -> FilmTimeResponse:
    return FilmTimeResponse(t=data["t"], nodes=tuple(int(n) for n in data["nodes"]),
                            displacement=data["displacement"], film_force=data["film_force"],
                            residual_force=data["residual_force"], film_solves=int(data["counts"][0]),
                            sor_fallbacks=int(data["counts"][1]), seconds=float(data["seconds"]))


def time_response(*args, **kwargs) -> FilmTimeResponse:
    """`film_time_response(*args, **kwargs)`, from the disk when this very integration was run before."""
    key = _key(args, kwargs)
    path = cache_dir() / "independent" / f"memo-{key}.npz"
    if path.exists():
        try:
            with np.load(path, allow_pickle=False) as f:
                data = {k: np.array(f[k]) for k in f.files}
            if str(data.pop("key")) == key and all(np.all(np.isfinite(v)) for v in data.values()):
                return _response(data)
        except (OSError, ValueError, KeyError, EOFError):
            pass
        path.unlink(missing_ok=True)
    tr = film_time_response(*args, **kwargs)
    arrays = _arrays(tr)
    if all(np.all(np.isfinite(v)) for v in arrays.values()) and math.isfinite(tr.seconds):
        equilibria._store(path, key, arrays)
    return tr


def integration_memoized(monkeypatch, *modules) -> None:
    """Each of `modules` calls `time_response` where it called `film_time_response`."""
    for module in modules:
        monkeypatch.setattr(module, "film_time_response", time_response)
