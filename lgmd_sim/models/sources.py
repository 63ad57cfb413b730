"""Where the published baselines come from: the code each one reproduces, as cited.

Kept apart from the models so that every baseline (and its parameters' sources) can cite
them without importing another model.
"""

from __future__ import annotations

__all__ = ["SOURCES"]

#: The published implementations the baselines reproduce: repository, file and the commit
#: read (docs/reference/models.md, "Baselines", lists the full commit ids).
SOURCES = {
    "pi-lgmd": "XuelongSun/InsectInspiredNavigation_PI-LGMD simulations/models.py @176e097 "
               "(LobulaGiantMotionDetectorModel.run)",
    "lgmd-single": "fuqinbing/LGMD-Plus-and-GAs-Open-Source code/LGMDSingle.cs @0dacd1f",
    "plgmd": "fuqinbing/pLGMD LGMD.m @7158bb3",
    "lgmd2": "fuqinbing/LGMD2-open-source lgmd2OpenSource.cs @11e4be5",
    "olgmd": "Ryannnice/Supplementary_Materials_FFI_ON_OFF Core_of_Source_Code/"
             "Computer_oLGMD_Python/optimized_LGMD.py @dca3097",
}
