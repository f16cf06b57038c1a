"""A behaviour-cloning baseline on the twin's environments (``pip install 'mearm[learn]'``).

State-based: a small MLP from ``agent_pos`` and ``environment_state`` (each object's
centre and class) to the next action, trained on the expert's episodes
(:mod:`mearm.learn.collect`, :mod:`mearm.learn.bc`) and evaluated by ``mearm
eval-policy --policy FILE.pt``. PyTorch is imported only when a baseline is trained or
run (:func:`mearm.learn.errors.import_torch`); nothing else in mearm needs it.
"""

from __future__ import annotations

from mearm.learn.errors import LearnExtraMissingError

__all__ = ["LearnExtraMissingError"]
