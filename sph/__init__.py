"""SPH part of the sandbox: anisotropic kernel (Sect. 4.1), neighbour search, materials,
principal values, corotated SPH elasticity (Eq. 1-3, 7-10) and the explicit `elastic` effect.

Modules import Taichi but do no Taichi work at import time; fields are built in constructors
after `core.runtime.init_taichi`.
"""
