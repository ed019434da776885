"""The folders of the web page, one module each; ``app.web.panel`` lists them in page order.

Each module defines one ``app.web.host.Folder``: it builds its widgets from the ``PanelHost`` it
receives, turns what a user does into checked commands, and shows the app's state.
"""
