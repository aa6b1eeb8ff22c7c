"""Puts this tree's locsim Python package first on sys.path, for the project's tools: `import
locsim_path` before `import locsim`. The package is python/locsim in the source tree and
share/locsim/python/locsim in an install (next to the installed tools); the tools use their own
tree's package, never another checkout's that a .pth may point at."""
import os
import sys

_here = os.path.dirname(os.path.abspath(__file__))
for _candidate in (os.path.join(_here, "python"), os.path.join(_here, "..", "python")):
    if os.path.isfile(os.path.join(_candidate, "locsim", "__init__.py")):
        sys.path.insert(0, os.path.normpath(_candidate))
        break
