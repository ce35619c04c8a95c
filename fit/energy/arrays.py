"""numpy or jax.numpy, following the arrays: one residual definition serves the jitted fit and host energies."""
from __future__ import annotations

from types import ModuleType
from typing import Union

import jax
import jax.numpy as jnp
import numpy as np

#: A host or device array: the residuals accept either.
Array = Union[np.ndarray, jax.Array]


def array_module(*arrays) -> ModuleType:
    """``jax.numpy`` when any argument is a JAX array (or tracer), else ``numpy``."""
    return jnp if any(isinstance(a, jax.Array) for a in arrays) else np
