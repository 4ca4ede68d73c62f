"""Measured and synthetic vibration records (SPEC §1, §4, §6): files, noise, full spectrum, features."""

from .features import PlaneFeatures, RecordFeatures, plane_features, record_features
from .noise import add_noise, noise_std
from .records import MAX_RECORD_BYTES, Record, check_speed, read_record, record_from_arrays, write_record
from .spectrum import FullSpectrum, full_spectrum

__all__ = ["MAX_RECORD_BYTES", "FullSpectrum", "PlaneFeatures", "Record", "RecordFeatures", "add_noise",
           "check_speed", "full_spectrum", "noise_std", "plane_features", "read_record", "record_features",
           "record_from_arrays", "write_record"]
