"""Seeing the robot: the offscreen GL backends (:mod:`~paa_mj.view.gl`) and the renderer of one frame
(:mod:`~paa_mj.view.renderer`), below everything that draws (the environments, the videos of
:mod:`paa_mj.outputs`).
"""
