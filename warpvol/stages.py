"""The stage catalog: every family's stages, one module per stage, kept beside its family's host code.

Importing this module registers the stages of every family :mod:`warpvol.family` finds (the built-in ones
by a scan of ``warpvol/``, others by their ``warpvol.families`` entry point); the pipeline does so before it
looks a stage up. The built-in families:

=======================================  ==========================================================================
package                                  stages
=======================================  ==========================================================================
``warpvol.conditioning.stages``          ``condition``: the scene centred, scaled to unit size and its scalars
                                         mapped by the transfer function's range, in float64 (first in the exact
                                         presets)
``warpvol.tables.stages``                pre-integration tables (``table_*``: exact, Roettger software/hardware,
                                         Guthe ping-pong and 2D tables, incremental/log axis, cylindrical planes,
                                         psi, iso-crossing)
``warpvol.projection.stages``            cell projection: ``vertex``, ``sort`` (centroid/MPVO/MPVONC/XMPVO),
                                         ``pt_*`` (classification, fragment programs of Roettger, Guthe, Kraus,
                                         ``pt_best``)
``warpvol.raycasting.stages``            ray casting: ``cell_setup``, ``entry_bins``, ``raycast``, ``peel``
                                         (consistent float32 walk) and ``harc_*`` (hardware ray casting, Espinha &
                                         Celes 2005)
``warpvol.vsbuffer.stages``              sweep planes: ``vsb_*`` (VSBUFFER, Westermann & Ertl 1997)
=======================================  ==========================================================================
"""

from warpvol.family import load_family_stages

load_family_stages()
