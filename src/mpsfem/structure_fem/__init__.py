"""Structure solver on scikit-fem: Euler-Bernoulli beams, Kirchhoff plates, Newmark-beta.

Public entry points:

* :class:`StructureParticipant` - the coupler-facing participant (interface, write, read,
  advance, max_dt, checkpoint, restore);
* :func:`run_structure` - a structure-only run under prescribed loads (``mpsfem structure``);
* :func:`modal_analysis` - natural frequencies and mode shapes (``mpsfem modes``);
* :func:`build_member`, :class:`BeamModel`, :class:`PlateModel`, :class:`Newmark`,
  :func:`natural_modes` - the building blocks.
"""

from .beam import BeamModel
from .modal import ModalResult, format_modes, natural_modes
from .model import MemberModel, build_member
from .newmark import Newmark, NewmarkState
from .participant import Interface, StructureParticipant
from .plate import PlateModel
from .standalone import StructureRunSummary, cli_main, modal_analysis, run_structure

__all__ = [
    "BeamModel",
    "Interface",
    "MemberModel",
    "ModalResult",
    "Newmark",
    "NewmarkState",
    "PlateModel",
    "StructureParticipant",
    "StructureRunSummary",
    "build_member",
    "cli_main",
    "format_modes",
    "modal_analysis",
    "natural_modes",
    "run_structure",
]
