"""Alpine racing with magnet gates (gates paper): magnet physics, gate crossings, anchor matching, gate-anchor."""
