"""A third campaign generator, written apart from the method and from the second generator.

``bayescal.twin.beams`` simulates Table III-style campaigns on a KR-270-class arm of its
own (only the URDF's joint origins and axes are shared with the cell; its link masses,
compensator, compliances, tool and tracker are its own numbers, near the cell's and
stated as such in :mod:`~bayescal.twin.beams.kr270` and :mod:`~bayescal.twin.beams.tracker`)
so that the method's checks meet physics and noise they were not built from.  It has:

* a large-displacement static equilibrium, solved by iteration, under gravity, a spring
  compensator between the column and the upper arm, and the hanging mass
  (:mod:`~bayescal.twin.beams.statics`);
* elastic gears, links as Timoshenko beams in bending, shear, stretch and torsion
  (:mod:`~bayescal.twin.beams.beam`), and a tool mount hinged about its own axis;
* a tracker whose noise differs along and across its line of sight and grows with
  incidence, reading times on a realistic clock, and reference nests
  (:mod:`~bayescal.twin.beams.tracker`, :mod:`~bayescal.twin.beams.schedule`);
* one planted effect per campaign (:mod:`~bayescal.twin.beams.effects`).

Usage::

    campaign = generate_campaign("data/table3_plan.csv", effect="drift", seed=3, nests=True)
    campaign.write("campaign.csv")        # and campaign_nests.csv
    campaign.truth["drift"]               # what was planted, units in its keys
"""

from bayescal.twin.beams.campaign import SimulatedCampaign, generate_campaign
from bayescal.twin.beams.effects import EFFECTS

__all__ = ["generate_campaign", "SimulatedCampaign", "EFFECTS"]
