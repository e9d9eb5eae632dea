"""Subsurface scattering: media, an exact reference and the BSSRDF's diffusion models."""

from brdfkit.bssrdf.chandrasekhar import chandrasekhar_reflectance, h_function
from brdfkit.bssrdf.medium import Medium, henyey_greenstein, sample_henyey_greenstein

__all__ = [
    "Medium",
    "chandrasekhar_reflectance",
    "h_function",
    "henyey_greenstein",
    "sample_henyey_greenstein",
]
