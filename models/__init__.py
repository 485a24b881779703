"""The robots' MJCF files (``models/`` at the top of the repository, installed as ``paa_mj.models``)."""
