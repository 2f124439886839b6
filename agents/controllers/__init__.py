"""Classical path trackers: pure pursuit, regulated pure pursuit and seed 003's guidance laws.

Their laws are numba kernels cached beside these sources. The kernels call only this
package's compiled functions (the env's arrays and constants reach them as arguments), so
this package's sources alone decide whether a cached kernel is current: any edit here drops
them all, as :mod:`mobile_envs._kernels.kernel_cache` does for the environments' kernels.
"""

import os

from mobile_envs._kernels.kernel_cache import invalidate_stale_kernel_caches

invalidate_stale_kernel_caches(os.path.dirname(os.path.abspath(__file__)))
