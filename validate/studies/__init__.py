"""Studies of cost and trust, data only (the command line prints them): bench (run time against
error), stress (numerical stability), chains (how cost grows with joints), float32 (MuJoCo Warp).
"""

__all__ = ["bench", "chains", "float32", "stress"]
