"""The scripting API: simulate a scenario, load runs, run studies (``mjx_radar.simulate``)."""
