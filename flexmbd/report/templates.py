"""The prose and structure of a case page (`pages.write_case`) as `string.Template`s: the page's
frame, and each section's title with its body in HTML and in Markdown.

A `$name` is filled from the page's table of numbers (`pages.numbers`) or from a piece made of
it (its figures, a table, a paragraph), the same value in both formats or the form each format
takes (`pages.Both`); values that go into HTML come escaped. The templates are constants of this
module, not package data: they ship with the code that fills them.
"""

from __future__ import annotations

from string import Template
from typing import NamedTuple


class Form(NamedTuple):
    """One piece of a page as a template in each of its two formats."""
    html: Template
    md: Template


class Section(NamedTuple):
    """One section of a case page: its title and its body's template in each format."""
    title: str
    html: Template
    md: Template


def same(text: str) -> Form:
    """A piece written alike in HTML and in Markdown (its values in the form of each)."""
    return Form(Template(text), Template(text))


# the page: its title, the link to the report's index (or how to build one), its sections in order
PAGE = Form(Template("<!doctype html><html><head><meta charset='utf-8'><title>$title</title><style>$css</style>"
                     "</head><body><p>$top</p><h1>$title</h1>$sections</body></html>\n"),
            Template("# $title\n\n$top\n$sections"))
PAGE_TITLE = Template("$name: $title")
SECTION = Form(Template("<h2>$title</h2>$body"), Template("\n## $title\n\n$body"))
INDEX = Form(Template("<a href='$up/index.html'>index</a>"), Template("[index]($up/index.md)"))
NO_INDEX = Form(Template("<code>$text</code>"), Template("`$text`"))
BUILD_INDEX = Template("no index yet: flexmbd report --no-run --out $out builds it from the stored results")

# the pieces sections are made of
IMAGE = Form(Template("<p><img src='$src' alt='$src'></p>"), Template("![$src]($src)\n\n"))
PARAGRAPH = Template("<p>$text</p>")
WHY = Form(Template("<p class='why'><b>$solver</b>: $status.$said</p>"), Template("**$solver**: $status.$said\n"))

# the sections, in the order of the page (`pages.SECTIONS` places them)
RUNS = Section("Runs", *same("$table$why"))
DEFLECTION = Section("Deflection", *same("$images"))
STRESS = Section("Stress at the stress points", *same("$images"))
ANGLES = Section("Joint angles, energy and reactions", *same("$images"))
SPECTRA = Section("FFT spectra and identified frequencies", Template("$images$note$table"),
                  Template("$images$note\n\n$table"))
FREQUENCY_MAP = Section("Frequency map", Template("$lead$images$table$files"), Template("$lead\n\n$images$table\n$files\n"))
MODES = Section("Mode shapes", Template("$images$note"), Template("$images$note\n"))
ELASTICITY = Section("Flexible minus rigid", *same("$images"))
TIMING = Section("Timing", *same("$table"))
ACCURACY = Section("Accuracy", Template("$lead$defaults$notes$table"), Template("$defaults$notes$table"))
DURABILITY = Section("Durability", Template("$lead$table$images$files"), Template("$lead\n\n$table\n$images$files\n"))
CONVERGENCE = Section("Convergence", *same("$body"))
PROVENANCE = Section("Provenance", *same("$table"))

# the tables' heads
RUNS_HEAD = ["solver", "verdict"]
PEAKS_HEAD = ["solver", "channel", "identified [Hz]", "system mode", "system [Hz]", "difference"]
TIMING_HEAD = ["solver", "status", "wall [s] (solve)", "set-up [s]", "compile [s]", "steps", "RHS evals",
               "wall / simulated s"]
PROVENANCE_HEAD = ["solver", "version", "case sha256", "git commit", "date", "machine", "Python, numba",
                   "overrides / source", "settings"]

# the prose: HTML, its Markdown the same text without the tags (`pages.plain`)
SPECTRA_NOTE = Template(
    "<p>Hann window, zero-padded 8x; a peak must stand clear of the main lobe and side lobes of every larger "
    "peak; refined by a parabola through the log-amplitudes. Each peak is named after the nearest frequency "
    "within 2 % of the system modes that move the channel's point in its direction: the case's equations "
    "(joint and modal coordinates) linearized about the initial state (<code>flexmbd modes CASE --system</code>, "
    "docs/formulation.md §10). A peak none of them explains is matched against the same system with $finer "
    "times the retained modes per beam (labels ending '(N modes)'): such a peak, of a finer solver, is a mode "
    "the retained set truncates or places too high. Peaks below half the lowest of them are the forced, "
    "quasi-static response and are not listed. A system whose configuration or spin changes much during the "
    "run (a swinging double pendulum, a spun-up beam) vibrates at shifting frequencies: its peaks are matched "
    "last against the system linearized about the run's state at evenly spaced instants (free joints at their "
    "recorded angles and rates, driven ones on their profile, modal coordinates at rest; labels ending 'at t = "
    "T s (frozen)'), a frozen-time approximation. A vibration whose amplitude the swing modulates also shows "
    "sidebands at its frequency plus and minus the swing's, which no mode explains.</p>")
ALIASES = Template(
    "<p class='outside'>$count system mode$lie above the Nyquist frequency $nyquist Hz of the $output ms output "
    "(the lowest: $lowest); sampled without filtering, they show as aliases at |f - k / dt|, which the table "
    "names.</p>")
MODES_NOTE = Template(
    "<p>The retained modes of each flexible body under its boundary condition ($conditions), as the modal "
    "solvers reduce it: the node displacements along the undeformed beam, transverse y and z (cubic between the "
    "nodes), and the axial displacement or the torsion angle of a mode led by it, each mode scaled to a largest "
    "value of 1 and titled with its frequency. These are the body's own modes, not the system's: the system "
    "modes (joints and bodies together, linearized about the initial state) are those the spectra are matched "
    "against, listed by <code>flexmbd modes $case --system</code>.</p>")
SEGMENTS_NOTE = Template(
    "$name is split into $count segments of $length m joined rigidly (<code>segments = $count</code>): the modal "
    "solvers give each segment the same retained modes, drawn here for the root segment $root.")
SEGMENTS_TITLE = Template("$case: retained modes of each of the $count segments of $name ($root shown; $boundary, "
                          "$length m)")
BODY_TITLE = Template("$case: retained modes of $name ($boundary, $length m)")
UNGRADED = Template("<p>Nothing graded: $ungraded.</p>")
REFERENCE = Template(
    "<p>Reference: <b>$reference</b>. Differences are normalised by the reference's maximum magnitude; the "
    "result compares the RMS difference with the case's tolerance. Phase-robust measures (over many cycles a "
    "small frequency difference becomes a large phase difference): dominant frequency, RMS difference of the "
    "amplitude envelopes and of the slow (low-pass below half the lowest natural frequency) parts.</p>")
DEFAULTS = Template("Defaults, not the case file's choices: $said (cases/README.md, [report]).")
DEFAULT_REFERENCE = Template("the reference $reference is the default (the first independent solver that runs the "
                             "case, in the order $order)")
DEFAULT_TOLERANCES = Template("the tolerances are the defaults of each channel's kind ($tolerances)")
