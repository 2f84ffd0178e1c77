"""Rigid bodies: mass properties from tets, boundary-sphere collision, impulse solver, sleeping,
splitting into fragments (DESIGN.md 5 "Rigid bodies", paper Sect. 5.3). See docs/notes_rigid.md.

Import the submodules directly (`rigid.world`, `rigid.bodies`, `rigid.mass`): nothing here touches
Taichi at import time.
"""
