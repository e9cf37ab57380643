"""``aaai play``: a person plays the levels in a web browser (docs, "Playing in the browser").

aaai.play.session holds one player's battery, paced in real time; aaai.play.server serves the page
and a WebSocket per tab (FastAPI and uvicorn, the ``play`` extra).
"""
