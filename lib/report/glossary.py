""" "Reading the report": what each word and figure of a report page means, in one place.

Every page carries this text folded at its end (a page is self-contained: mailed or opened from a phone, a
link into the repository would not open), and ``docs/reading-the-report.md`` holds the same text
(:func:`glossary_markdown`; a test keeps the two equal).
"""

from __future__ import annotations

from sportfusion.report import html as H

#: Below this speed [m/s] an athlete on skis counts as standing (the start gate, after the finish):
#: moving time and moving mean speed leave those samples out.
MOVING_SPEED = 1.0

#: (term, explanation) in reading order: the headline first, then the figures, then the tables.
GLOSSARY: tuple[tuple[str, str], ...] = (
    (
        "Jump length",
        "Distance along the landing hill's certified profile from its start under the take-off edge (point F) "
        "to the foot of the perpendicular from the sensor at the touch-down, in metres (jump-metrics). "
        "The sensor is still a few decimetres above the snow at that instant; the jump length of the rules "
        "(first ski contact, read by the judges or a video) can differ by about a metre.",
    ),
    ("Take-off speed", "The estimated speed |v| at the take-off instant, in m/s and km/h (1 m/s = 3.6 km/h)."),
    ("Flight time", "Touch-down minus take-off, in seconds: the time the athlete is in the air."),
    (
        "Max height",
        "The largest vertical distance of the sensor above the landing slope during the flight, in metres "
        "(measured straight down to the profile, not perpendicular to it).",
    ),
    (
        "Take-off, touch-down",
        "The instants detect-events finds in the accelerometer (the push-off at the table's edge and the landing "
        "impact's onset); dashed lines and circles in the figures.",
    ),
    (
        "Moving time",
        f"The time the estimated speed is at least {MOVING_SPEED:g} m/s ({3.6 * MOVING_SPEED:.1f} km/h): standing "
        "in the start gate or after the finish is left out. The recording's length is given beside it.",
    ),
    (
        "Moving mean speed",
        "The distance travelled while moving divided by the moving time, in m/s and km/h.",
    ),
    ("Max speed", "The largest estimated speed |v| of the session."),
    (
        "Distance",
        "The length of the estimated path (the smoothing spline's arc length, or the integrated speed), in metres.",
    ),
    (
        "Gates matched",
        "Gates whose magnet crossing was detected and matched to the survey, out of the gates surveyed. "
        "Crossings detected: every magnetic-field peak the detector took for a gate; a crossing that matches "
        "no surveyed gate (a stray magnet, a fall) is listed as unmatched.",
    ),
    (
        "Turn (speed in, speed out, path length)",
        "A turn runs from the switch before its gate to the switch after it (a switch: the path's curvature "
        "changes sign, between two consecutive crossings; with the athlete's body measured, the instant both "
        "ankles are equally far from the centre of mass). Speed in and out are the speeds at the switches; "
        "the path length is the 3-D length from switch to switch. A gate has no turn when it is the first or "
        "the last crossing (no switch before or after it), when it was not matched, or when no switch lies "
        "between it and a neighbouring crossing; the Turns table says which.",
    ),
    (
        "Centre of mass (CoM)",
        "With sensors on the legs, pelvis, trunk and head (body-model), the athlete's centre of mass, boots and "
        "skis included, instead of the sacrum: its line (the CoM's path from the first to the last matched "
        "gate, in metres), its height above the skis (the mean of the two ski-snow contact points) at each "
        "gate, its distance to the gate's magnet at the crossing and at the turn switches, and the posture at "
        "the gates seen from behind.",
    ),
    (
        "Holds reached, grips",
        "Different holds the hand was on, and grips on holds in order (a hold gripped twice counts once "
        "among the holds reached).",
    ),
    (
        "Hold certainty",
        "How sure the particle filter is about the hold under the hand: the probability of its most likely "
        "hold, averaged over the grips (1: every particle agrees; 0.5: two holds equally likely).",
    ),
    (
        "Frames",
        "Positions are in the session's local frame: x along the hill's or course's axis (its azimuth from "
        "north is given), y to the right, z down (heights are drawn as -z); a climbing wall's map frame: x "
        "right along the wall, y into it, z up. Attitude (roll, pitch, yaw) is the sensor's against north, "
        "east and down, in degrees.",
    ),
    (
        "1-sigma",
        "The estimator's own uncertainty: about two thirds of the errors are smaller than it. The bands "
        "around the curves and the 'How sure we are' table show it.",
    ),
    (
        "RMS against the truth",
        "For a simulated session (or one with a reference): the root-mean-square of estimate minus truth "
        "over the samples of a phase (in-run, flight, out-run, or the whole session), position in metres, "
        "velocity in m/s, attitude in degrees, in the frame the table names.",
    ),
    (
        "For the analyst",
        "The estimated sensor errors (gyroscope and accelerometer biases) and the processing steps with "
        "their settings (provenance): folded, for the person who checks the processing.",
    ),
)


def glossary_html() -> str:
    """The glossary as a definition list (HTML)."""
    return "<dl class='glossary'>" + "".join(f"<dt>{H.esc(t)}</dt><dd>{H.nums(d)}</dd>" for t, d in GLOSSARY) + "</dl>"


def glossary_markdown() -> str:
    """The glossary as Markdown (the body of docs/reading-the-report.md)."""
    return "\n".join(f"**{t}** — {d}\n" for t, d in GLOSSARY)
