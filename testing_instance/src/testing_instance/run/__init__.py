"""One run of a scenario: the one loop in sim time, driven by a clock (the world in lockstep, or a
recording played back), the intake of messages, the inbox, the actions as objects, the recording."""
