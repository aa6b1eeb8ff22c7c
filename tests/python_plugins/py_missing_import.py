"""Test plugin: imports a module that does not exist."""
import numpy as np
import locsim_no_such_module  # noqa: F401

import locsim


class MissingImport(locsim.Localizer):
    """Cannot be imported (tests)."""

    def estimate(self):
        return np.zeros(3), np.eye(3)
