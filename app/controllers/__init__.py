"""What the app does, without Qt: each controller owns one concern (a run, the live preview,
the surface colours, sessions and export, the frame pacing) and talks to the model through its
methods and events. Work that takes time runs on a :class:`~scribbleseg_app.controllers.jobs.Job`
thread; its results reach the main thread through a :class:`~scribbleseg_app.controllers.jobs.Dispatcher`,
so tests drive every controller without a display."""
