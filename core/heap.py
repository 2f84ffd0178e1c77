"""Python's cycle collector kept off a run's frames (issue 16: no frame over 100 ms, start under 3 s).

CPython's collector traverses every tracked object of a generation when it collects it. A run's
process holds about 80k of them after its imports and build (modules, functions, Taichi's Python
objects, the scene), nearly all alive until it ends, and the oldest generation's collection walked
them all: 36-83 ms a pass on this machine, three passes a run of the pot, glass_r5 or the Tai Chi
disc, two of them in the middle of a frame (measured with `gc.callbacks`, session 38; glass_r5's
frame 57 took 76 ms more in its debris stage for one).

`freeze_long_lived()` moves every object alive at the call into the permanent generation
(`gc.freeze`, Python 3.7+), which no collection traverses: later passes walk only what was made
since. Reference counting still frees frozen objects; only a reference cycle among them is not
collected while the process runs, and what is alive after the imports and the build is the run's
for its whole life. At exit they are unfrozen (`atexit`), so that the interpreter's last collection
finalises them as before: Taichi writes its offline cache when its program object is finalised
there, and a frozen one never was (every run compiled again what the last one compiled).
It is a decision about a whole process, so only processes the project owns call it: `main.py` run
as the program (after its imports and after the World's build; `main.main()` called from Python
does not) and the drawing process (after it made its renderer). A World built through the Python
API (a notebook) leaves the collector as it was.
"""

from __future__ import annotations

import atexit
import gc

_exit_hook_registered = False  # gc.unfreeze is registered with atexit once


def freeze_long_lived() -> int:
    """Exclude every object alive now from later collections until the process exits (module doc);
    returns how many objects the permanent generation holds."""
    global _exit_hook_registered
    if not _exit_hook_registered:
        atexit.register(gc.unfreeze)
        _exit_hook_registered = True
    gc.freeze()
    return gc.get_freeze_count()


__all__ = ["freeze_long_lived"]
