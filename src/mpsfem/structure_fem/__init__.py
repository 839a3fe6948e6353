"""Structure solver on scikit-fem: Euler-Bernoulli beams (linear or co-rotational), Kirchhoff
plates (linear or von Karman), Newmark-beta and HHT-alpha (Newton iterations for nonlinear
members).

Public entry points:

* :class:`StructureParticipant` - the coupler-facing participant (interface, write, read,
  advance, max_dt, checkpoint, restore);
* :func:`run_structure` - a structure-only run under prescribed loads (``mpsfem structure``);
* :func:`modal_analysis` - natural frequencies and mode shapes (``mpsfem modes``);
* :func:`build_member`, :class:`BeamModel`, :class:`CorotationalBeamModel`,
  :class:`PlateModel`, :class:`VonKarmanPlateModel`, :class:`Newmark`,
  :class:`NonlinearNewmark`, :func:`natural_modes` - the building blocks; :class:`NewtonFailure`
  and :class:`LargeRotationWarning` what they raise.
"""

from .alpha_method import NonlinearNewmark
from .beam import BeamModel
from .corotational_beam import CorotationalBeamModel
from .modal import ModalResult, format_modes, natural_modes
from .model import MemberModel, build_member
from .newmark import Newmark, NewmarkState
from .newton import NewtonFailure
from .participant import Interface, LargeRotationWarning, StructureParticipant
from .plate import PlateModel
from .standalone import StructureRunSummary, cli_main, modal_analysis, run_structure
from .von_karman_plate import VonKarmanPlateModel

__all__ = [
    "BeamModel",
    "CorotationalBeamModel",
    "Interface",
    "LargeRotationWarning",
    "MemberModel",
    "ModalResult",
    "Newmark",
    "NewmarkState",
    "NewtonFailure",
    "NonlinearNewmark",
    "PlateModel",
    "StructureParticipant",
    "StructureRunSummary",
    "VonKarmanPlateModel",
    "build_member",
    "cli_main",
    "format_modes",
    "modal_analysis",
    "natural_modes",
    "run_structure",
]
