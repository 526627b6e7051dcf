"""Bounds on how often a test at a known rate may fire, for the calibration tests."""
import math


def binomial_quantile(n, p, q=0.999):
    """The smallest k with P(X <= k) >= q for X ~ Binomial(n, p): how many of n tests at level p
    may reject a true hypothesis before the level itself is in doubt."""
    chance, k = 0.0, 0
    while True:
        chance += math.comb(n, k) * p**k * (1 - p)**(n - k)
        if chance >= q:
            return k
        k += 1
