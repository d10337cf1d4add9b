"""Production experiments, ROS-free: seeded random inputs of a cell (arrivals, fault processes).

``streams`` gives replication i one independent random stream per purpose (common random numbers),
``arrivals`` how parts arrive (a scene's ``arrivals:`` section), ``faults_process`` when devices fail and
are repaired (a scene's ``faults:`` section). docs/experiments.md describes the method.
"""
