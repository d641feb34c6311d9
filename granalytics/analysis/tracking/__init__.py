"""Granule life histories: tracking across frames, coalescence and breakage, population-balance rates.

Granules identified in successive frames are linked through the particles they share (particles
are matched by their *ids*, never by row). Every granule of every frame belongs to exactly one
*track*; a track starts at an ``"initial"`` granule (first frame), a ``"birth"``, a
``"coalescence"`` or a ``"breakage"``, and ends ``"alive"`` (last frame), by ``"death"``,
``"coalescence"`` or ``"breakage"``. The definitions are in :func:`track_granules` and in
``docs/tracking.md``; ``continuation="main"`` lets the main branch keep its track through
coalescence and breakage (the same events, other track ids).

- :mod:`.linking`: :func:`track_granules`, :func:`track_run` (the loop over frames);
- :mod:`.steps`: one step k → k+1: particles matched by id, the links between granules, which
  granule continues which track, the step's events;
- :mod:`.tracks`: the result, :class:`GranuleTracks`, and the event kinds :data:`KINDS`;
- :mod:`.rates`: :func:`event_rates` (with :func:`rate_errors`), :func:`coalescence_kernel` (as a
  matrix: :func:`kernel_matrix`), :func:`breakage_rate` (the rate functions of a population balance);
- :mod:`.histories`: :func:`size_histories`, the sizes of the longest-lived tracks.

Units: SI, time in seconds (``_s`` suffix); granule sizes in particles.
"""

from granalytics.analysis.tracking.histories import size_histories
from granalytics.analysis.tracking.linking import track_granules, track_run
from granalytics.analysis.tracking.rates import breakage_rate, coalescence_kernel, event_rates, kernel_matrix, rate_errors
from granalytics.analysis.tracking.tracks import KINDS, GranuleTracks


__all__ = ["GranuleTracks", "track_granules", "track_run", "event_rates", "coalescence_kernel", "breakage_rate",
           "KINDS", "rate_errors", "kernel_matrix", "size_histories"]
