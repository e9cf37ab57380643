"""``aaai play``: a person plays the levels in a web browser (docs, "Playing in the browser").

aaai.tools.play.session holds one player's battery, paced in real time; aaai.tools.play.server serves the page
and a WebSocket per tab (FastAPI and uvicorn, the ``play`` extra).
"""
