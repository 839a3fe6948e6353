"""Structure solver on scikit-fem: Euler-Bernoulli beams, Kirchhoff plates, Newmark-beta."""
