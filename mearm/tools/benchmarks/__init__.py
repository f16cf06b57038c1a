"""The sections of ``mearm bench`` (:mod:`mearm.tools.bench`), one module each."""
