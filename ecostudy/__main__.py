from ecostudy.cli import app

app()
