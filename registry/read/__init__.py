"""Reading back: recorded versions, and the nightly record.

``loading``  safe loading of a version (verified, never unpickled)
``history``  the zeta history and the recorded alerts (made again from the stored drifts)
"""
