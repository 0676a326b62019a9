"""The live mission: the planner drives real (or mock) vehicles over MAVLink.

``mission`` connects and checks the fleet and runs one ``agent`` task per
vehicle; each agent asks the shared planner (``shared``) for its next move
when its vehicle has arrived, flies it through ``pilot`` and senses with
``sensing``; ``energy`` estimates each vehicle's battery use per metre from
its telemetry; ``record`` turns what happened into a ``RunResult``;
``display`` shows it all to the operator.
"""
