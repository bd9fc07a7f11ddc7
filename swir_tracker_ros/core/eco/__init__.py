# SPDX-License-Identifier: Apache-2.0
"""ECO base filter (Danelljan et al., CVPR 2017; C-COT, ECCV 2016): docs/eco.md. Import from the modules
(`core.eco.filter.ECOFilter`, `core.eco.params.ECOParams`, `core.eco.tracker.ECOTracker`); the package itself
imports nothing, so no module imports back through it."""
