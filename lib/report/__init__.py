"""Reports for people (cross-cutting: any sport): one self-contained HTML page per session
(:func:`~sportfusion.report.session.session_report`) and an index page per batch
(:func:`~sportfusion.report.batch.batch_index`).  No server, no network: a file that opens anywhere."""
