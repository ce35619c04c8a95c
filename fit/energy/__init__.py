"""The fairness energy: one definition per term, used by the global fit, the local re-fair
and the host normal matrix alike."""
from .residuals import *  # noqa: F401,F403
from .residuals import (  # noqa: F401
    TERMS, angle_residual, assemble_normal_matrix, bend_residual, bend_tables, bend_weights, blended_targets,
    control_points, energies, patch_expansion, residuals,
)
