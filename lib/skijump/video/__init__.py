"""Video reference for the jump length (skijump paper, Appendix B).

* :mod:`~sportfusion.skijump.video.camera` -- pinhole camera beside the landing slope,
  slope coordinates, the slope-plane homography;
* :mod:`~sportfusion.skijump.video.markers` -- the marker calibration table (CSV);
* :mod:`~sportfusion.skijump.video.calibration` -- image <-> slope mapping fitted to the markers;
* :mod:`~sportfusion.skijump.video.scene`, :mod:`~sportfusion.skijump.video.jumper`,
  :mod:`~sportfusion.skijump.video.render` -- rendering a landing as a side camera films it;
* :mod:`~sportfusion.skijump.video.measure` -- touch-down frame and jump length read from a video;
* :mod:`~sportfusion.skijump.video.annotate` -- annotated frames and a pixel grid for people.

FFmpeg's own log lines (e.g. "moov atom not found" for a file that is not a
video) would break the one-line error contract, so they are silenced unless
``OPENCV_FFMPEG_LOGLEVEL`` is set.
"""

import os

os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # AV_LOG_QUIET
