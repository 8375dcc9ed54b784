"""Friction compensation in the loop, without ROS: a MuJoCo-simulated arm with hidden friction
(:mod:`.sim`), a tracking controller (:mod:`.control`) and the safety gate of online
re-identification (:mod:`.gate`). MuJoCo and Pinocchio are imported on first use."""
