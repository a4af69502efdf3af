"""A population of people: person-sized walkers with two legs, each walking the regions'
Markov chain, moved by a social-force model against walls, each other and the robots.

* config.py: the world.yaml ``people:`` section;
* forces.py: the social-force terms, per unit mass;
* routes.py: paths to regions, one shortest-path tree per region;
* crowd.py: the people's state and one step of all of them, and where their legs are.

The world steps the crowd and its lidars see the legs (sim/world.py, sim/leg_beams.py).
"""
