"""coupled-oscillators applications: the command line, the web app, the recorder, the study tools.

Everything here drives ``sim`` through its runner; ``sim`` knows nothing of these front ends.
"""
